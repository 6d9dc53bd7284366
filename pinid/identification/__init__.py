"""The results of identification, the runner behind identify and compare, the identified model."""
