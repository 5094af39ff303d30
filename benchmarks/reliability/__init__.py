"""Reliability: stability over the design box and the CLI under bad input, malformed files and kills."""
