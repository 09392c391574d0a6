"""The job's stages: calibrate, scan, register, program, check, verify, execute.

Each stage is handed a `StageContext` (the controller API, the virtual model, its planning
settings, the hooks into its run) and returns a frozen result. Nothing here can reach the
simulated truth: the import contracts forbid it, and the context does not hold it.
"""
