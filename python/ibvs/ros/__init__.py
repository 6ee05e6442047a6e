"""ibvs.ros (placeholder)."""
