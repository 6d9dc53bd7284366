"""Flexible (belt, cable, series-elastic) joints and output-error identification."""
