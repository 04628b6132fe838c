"""erosim.hydrology"""
