"""erosim.kernels"""
