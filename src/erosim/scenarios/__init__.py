"""erosim.scenarios"""
