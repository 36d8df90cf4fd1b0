"""API blueprint: JSON endpoints (votes, progress, job status)."""
