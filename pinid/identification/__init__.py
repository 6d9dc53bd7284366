"""The identification problem, its results, the runner behind identify and compare, the identified model."""
