"""erosim.core"""
