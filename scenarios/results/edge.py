"""The project's file edge: a mapping as a JSON or YAML file holds it (results.json, a
trial's row, a configuration and its overrides, the register command's JSON). Only the code
that reads or writes such a file handles one; everything between is typed."""

from typing import Any

JsonObject = dict[str, Any]
"""A JSON or YAML object, as read from a file or about to be written to one."""
