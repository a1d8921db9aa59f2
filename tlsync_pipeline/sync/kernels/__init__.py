"""Fitting kernels: the paper's RANSAC line, the adaptive line search, the slope prior, trajectory smoothing."""
