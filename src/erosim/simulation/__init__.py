"""erosim.simulation"""
