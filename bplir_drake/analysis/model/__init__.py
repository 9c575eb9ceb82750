"""The model on its own: energy, the compound-pendulum periods, the
linearisation of the plant, free swings and the friction model's table
(Table 4.1)."""
