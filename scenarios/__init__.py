"""Runnable jobs and everything around them. Each part is imported from its own package:

- `scenarios.jobs`: the job configurations (`scenarios.jobs.config.load_config`), the runner
  (`scenarios.jobs.runner.run_job`, `RunOptions`), the pipeline of a cell job and its typed
  result (`scenarios.jobs.result.RunResult`), the seed paper's experiments;
- `scenarios.stages`: the job's stages, each handed a context that holds the controller API,
  the virtual model and its planning settings;
- `scenarios.offline`: the planning the stages use (scan planning, calibration, programs,
  the pre-motion check, RAPID), which never sees the simulated truth;
- `scenarios.realcell`: the job's real cell (its setup in simulation) and the evaluator, the
  only reader of the truth;
- `scenarios.outputs`: the run folder's files, figures and the rerun recording;
- `scenarios.campaign`: many runs over seeds and settings; `scenarios.cli`: the command line.

    >>> from scenarios.jobs.runner import RunOptions, run_job
    >>> folder, results = run_job("skull", seed=3, options=RunOptions(rrd=False))
"""
