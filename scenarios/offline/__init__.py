"""Offline programming: what plans, scans, localizes, calibrates and corrects, seeing the real
cell only through the controller API."""
