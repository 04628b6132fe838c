"""erosim.io"""
