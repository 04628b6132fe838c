"""erosim.terrain"""
