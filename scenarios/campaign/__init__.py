"""Campaigns: many seeded trials of a stage (registration alone, or the full scenario),
crossed sweeps of config keys, a local or Dask backend, resumable storage, a report.

    >>> from scenarios.campaign import plan_campaign, run_campaign
    >>> spec = plan_campaign(
    ...     "skull", stage="register", trials=50, vary=["register_trial.case=default,outliers"]
    ... )
    >>> outcome = run_campaign(spec, "runs/campaigns/demo", workers=2)
"""

from scenarios.campaign.campaign import (
    BACKENDS,
    CampaignOutcome,
    CampaignSpec,
    base_config,
    campaign_trials,
    default_out,
    plan_campaign,
    resolve_config,
    run_campaign,
)
from scenarios.campaign.campaign_errors import CampaignError
from scenarios.campaign.campaign_report import GroupSummary, campaign_summaries, summarize
from scenarios.campaign.store import ResultStore, read_csv
from scenarios.campaign.sweep import parse_vary, set_dotted, sweep_points
from scenarios.campaign.trials import STAGES, Trial, run_trial

__all__ = [
    "BACKENDS",
    "STAGES",
    "CampaignError",
    "CampaignOutcome",
    "CampaignSpec",
    "GroupSummary",
    "ResultStore",
    "Trial",
    "base_config",
    "campaign_summaries",
    "campaign_trials",
    "default_out",
    "parse_vary",
    "plan_campaign",
    "read_csv",
    "resolve_config",
    "run_campaign",
    "run_trial",
    "set_dotted",
    "summarize",
    "sweep_points",
]
