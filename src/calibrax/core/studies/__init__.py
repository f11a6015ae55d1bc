"""The studies: the calibration campaign, fixed sets of simulations (crosscheck, convergence), run through the scheduler."""
