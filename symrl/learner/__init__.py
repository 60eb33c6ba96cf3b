"""The learner: growing RBF experts, the mixture-of-experts policy, the TESEO update, configs."""
