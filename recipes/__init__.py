"""The shipped recipes (YAML files beside this one): ``symrl train NAME`` loads ``NAME.yaml``."""
