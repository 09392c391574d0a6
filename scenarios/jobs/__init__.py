"""Jobs: the shipped configurations, the runner that executes a job's stages, and the run's
result."""
