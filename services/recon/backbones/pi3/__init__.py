"""Our own PyTorch Pi3 and Pi3X (permutation-equivariant visual geometry) that load the published
checkpoints `yyfz233/Pi3` and `yyfz233/Pi3X`.

`model.Pi3` / `model.Pi3X` are the networks, `checkpoint.load_pi3` fills them strictly,
`preprocessing` resizes images as published, and `backbone` serves them to the recon service
(imported lazily by the backbone registry). Transformer parts are shared with VGGT
(`services/recon/backbones/transformer/`).
"""
