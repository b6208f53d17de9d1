"""The config tree as a package, ``lwrlab.conf`` (``lwrlab/conf`` links here; a wheel copies it in).

Hydra reads it as ``pkg://lwrlab.conf`` (see :mod:`lwrlab.resources`); this file only makes the folder
a package, which Hydra requires of a primary config source.
"""
