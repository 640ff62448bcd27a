"""Data quality analysis: findings, levels 1-3, signal selection and the QA pipeline."""
