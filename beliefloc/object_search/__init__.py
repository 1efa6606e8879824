"""Object search (Zhang, Sridharan & Wyatt 2015): a belief over the target's cell from a knowledge-base
prior and kept observation likelihoods, and metareasoning about whether the target exists at all."""
