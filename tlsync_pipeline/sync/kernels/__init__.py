"""Fitting kernels: the paper's RANSAC line, the adaptive line search, the slope prior, trajectory smoothing, the robust
sparse Levenberg-Marquardt of the joint fits, the one BLAS thread they run with."""
