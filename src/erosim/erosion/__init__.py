"""erosim.erosion"""
