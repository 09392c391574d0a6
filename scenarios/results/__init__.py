"""The typed results of a run, from the stage that makes them to results.json and back.

- `scenarios.results.run`: `RunResult` (the whole cell job), with its goals' checks, and the
  schema version of results.json;
- `scenarios.results.json_converter`: the one JSON converter (cattrs) that writes every
  result (`unstructure`) and reads it back (`structure`), with results.json's layout;
  `scenarios.results.results_file`: a run folder's results.json read back (`read_results`);
- `scenarios.results.method_reports`: the run's surface match and each localization
  method's report;
- `scenarios.results.evaluations`: what the evaluator measured against the truth (targets,
  poses, the pick) and the calibration's figures;
- `scenarios.results.events`: what the supervision and the stages' checks saw, and each
  injected fault with what detected it;
- `scenarios.results.exported_result`: the exported program as run by a controller without
  absolute accuracy; `scenarios.results.scan_plan_result`: the scan's plan;
- `scenarios.results.result_table`: a run's results as a table for the terminal.

Nothing here reads the simulation: these are values, written by the runner and read back by
anyone (`twincell execute`, the campaigns, the README's tables).
"""
