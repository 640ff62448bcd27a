"""Readers, templates and writers."""
