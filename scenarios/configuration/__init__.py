"""Job configurations: YAML files validated by pydantic (an unknown key or a bad value is
named, with the valid keys near it). The sections of the cell (`cell_sections`), its faults
(`fault_sections`), a campaign's register trial (`register_trial_sections`), the whole job
(`job_config`), and the reading of files and overrides (`config_files`).

A cell job is one configuration of the one pipeline (scenarios.jobs.pipeline):
- `cell`: the robot, the object and how it is placed, the cell's error sources;
- `model`: where the virtual model comes from (the object's design, or its simulated CT);
- `calibration`: the in-cell kinematic calibration before anything else;
- `localization`: 3D surface matching (`surface`), 2D IR edge probing (`probe`), or both
  side by side (the first one's pose drives the program);
- `operations`: what the program does and where its targets come from;
- `checks`: the goals the run is held to.
- `register_trial` (campaigns only, optional): what only a register-stage trial has, a
  simulated scan matched to the virtual model without the cell
  (scenarios.campaign.register_trial); a job's run ignores it.
The seed paper's experiments (`kind: paper`) are a job of their own.

Shipped configurations live in `scenarios/configuration/shipped/<name>.yaml` (cells in its
`cells/`); `load_config("skull")` reads a shipped one, `load_config("my.yaml")` a user's
file, and `--set KEY=VALUE` overrides any value by its dotted key. Values are SI ([m], [rad]
where the key says so, degrees only in keys ending in `_deg`).
"""
