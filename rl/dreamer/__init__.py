"""DreamerV3 (Hafner et al. 2023) on the vector-env contract: a recurrent world model (RSSM
with discrete latents) learned from replayed sequences, and an actor-critic trained in its
imagination. config.py holds the hyperparameters (importable without torch), the other
modules the distributions, the world model, the actor-critic, the sequence replay and the
agent the runner drives (agent.Dreamer).
"""
