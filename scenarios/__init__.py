"""Runnable jobs and everything around them. Each part is imported from its own package:

- `scenarios.configuration`: the job configurations
  (`scenarios.configuration.config_files.load_config`);
- `scenarios.jobs`: the runner (`scenarios.jobs.runner.run_job`, `RunOptions`), the job
  planned in its virtual cell, the pipeline of a cell job (its stages run in one loop) and
  its report against the truth, the seed paper's experiments;
- `scenarios.stages`: the job's stages, each handed a context that holds the controller API,
  the virtual model, its planning settings and the job so far;
- `scenarios.offline`: the planning the stages use (scan planning, calibration, programs,
  the pre-motion check), which never sees the simulated truth; `scenarios.rapid`: RAPID in
  and out;
- `scenarios.realcell`: the job's real cell (its setup in simulation), the evaluator, the
  only reader of the truth, and the rerun recording;
- `scenarios.results`: the run's typed results, written to results.json and read back
  (`RunResult`, offered here too);
- `scenarios.outputs`: the run folder's files and figures;
- `scenarios.campaign`: many runs over seeds and settings; `scenarios.cli`: the command line.

    >>> from scenarios.jobs.runner import RunOptions, run_job
    >>> folder, result = run_job("skull", seed=3, options=RunOptions(rrd=False))
    >>> from scenarios.results.results_file import read_results
    >>> read_results(folder).target_error_max_m == result.target_error_max_m
    True
"""

from scenarios.results.run import RunResult

__all__ = ["RunResult"]
