"""erosim.validation"""
