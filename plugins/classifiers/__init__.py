"""Tool classifiers (config group ``classifier``): recognise a tool from its identified parameters."""
