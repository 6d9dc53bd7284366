"""The robot: URDF loading, bundled robots, regressor and joint terms, base parameters, physical consistency, export."""
