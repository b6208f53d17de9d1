"""Reading and writing the value objects (trajectories, measurements, identified models, tables)."""
