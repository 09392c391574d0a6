"""Runnable jobs: paper, skull, assembly; offline programming, evaluation, logging, CLI."""
