"""One module per scene: ``build(params) -> Multibody`` turns parameter values into physics."""
