"""Controllers on an identified (or any) dynamics model, closed loop on the twin."""
