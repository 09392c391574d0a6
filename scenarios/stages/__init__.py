"""The job's stages: calibrate, probe, scan, register, check, verify, execute, export.

Each stage is an object (scenarios.stages.stage.Stage) whose `run(ctx)` returns a frozen
outcome; the context (scenarios.stages.context.StageContext) holds the controller API, the
virtual model, the planning settings and the job so far (scenarios.stages.state.JobState),
and one loop (scenarios.stages.loop.run_stages) runs them. Nothing here can reach the
simulated truth: the import contracts forbid it, and the context does not hold it.
"""
