"""What the benchmark scripts share (and the tests that keep their figures true import):
the per-seed tables of docs/benchmarks.md made from runs (readme_table_rows)."""
