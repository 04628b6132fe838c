"""erosim.sph"""
