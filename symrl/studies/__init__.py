"""Studies: repeatability (Table 1), ablations, the optimum planner, baselines, figures."""
