"""The painting path of Fig. 7, its optimisation (eq. 12), and the painted coverage."""
