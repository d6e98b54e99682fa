"""Models: exact tabular (P, R) models and generative samplers shared by planners (ch. 2)."""
