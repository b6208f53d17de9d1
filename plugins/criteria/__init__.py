"""Excitation criteria (config group ``criterion``): one module each, ``J(W_b)`` and ``∂J/∂W_b``."""
