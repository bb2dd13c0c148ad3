"""Stage 1, parameters: the paper's Table I as a sampler config and the parameters of one
module (`ModuleParams`, SI units), validated with errors that name the value, its range and
what to do. A seed and a config give the same parameters on every machine."""
