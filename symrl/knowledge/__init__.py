"""The paper's two pieces of prior knowledge: the region mapper and the fuzzy reflex."""
