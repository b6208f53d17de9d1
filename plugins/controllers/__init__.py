"""Painting controllers (config group ``controller``): the PaintingController protocol of lwrlab.control."""
