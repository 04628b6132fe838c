"""erosim.analysis"""
