"""erosim.bench"""
