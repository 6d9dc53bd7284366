"""The digital twin: closed-loop simulation with friction, noise and quantisation."""
