"""Robustness suite: every command and reader against bad input, odd images and interruptions (issue 8)."""
