"""Simulation: momentum-exact plant, scenarios, closed-loop runs, outputs and replay."""
