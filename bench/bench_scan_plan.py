"""The scan planner in the virtual cell: the fixed plan and the chosen one side by side, by
prediction (worst predicted TRE at the targets, predicted cell time of the scan) and the
planner's own wall time. No physics: the measured figures come from campaigns
(`twincell campaign JOB --stage full --set localization.scan.plan=auto`).

    python bench/bench_scan_plan.py [JOB ...] [--short]

Jobs: skull and assembly unless named. --short: the skull job alone.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import job_robot, object_models
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.operations import target_operations
from scenarios.stages.scan_stage import job_scan_plan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("jobs", nargs="*", default=["skull", "assembly"])
    parser.add_argument("--short", action="store_true", help="the skull job alone")
    args = parser.parse_args()
    jobs = ["skull"] if args.short else args.jobs
    print(f"{'job':10} {'plan':6} {'passes':>6} {'cell time [s]':>14} {'worst TRE [mm]':>15} "
          f"{'planner [s]':>12}")  # fmt: skip
    for job in jobs:
        for mode in ("fixed", "auto"):
            config = load_config(job, {"localization.scan.plan": mode})
            settings = config.planning()
            virtual, _ = object_models(config)
            T = nominal_pose(settings.placement, virtual.mesh.vertices)
            ops = target_operations(virtual, config.operations)
            targets = np.array([op.T_object_touch[:3, 3] for op in ops])
            t0 = time.perf_counter()
            plan = job_scan_plan(job_robot(config.cell.robot), settings, virtual, T, targets,
                                 lambda _m: None, tuple(op.name for op in ops))  # fmt: skip
            wall = time.perf_counter() - t0
            print(f"{job:10} {mode:6} {len(plan.passes):6d} {plan.predicted_time_s:14.1f} "
                  f"{plan.predicted_tre_max_m * 1e3:15.3f} {wall:12.1f}")  # fmt: skip
            for c in plan.chosen:
                print(f"    {c.name:45} share {c.information_share:5.2f}  {c.seconds:5.1f} s")


if __name__ == "__main__":
    main()
