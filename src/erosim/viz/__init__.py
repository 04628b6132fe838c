"""erosim.viz"""
