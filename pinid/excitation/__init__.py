"""Fourier excitation trajectories and their design under joint limits."""
