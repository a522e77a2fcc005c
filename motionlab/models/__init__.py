"""One file per model, each readable top to bottom beside its paper.

:data:`MODELS` maps the names the command line (``python -m motionlab.train NAME``) knows
to ``(module, model class, config class)``. :data:`CHECKPOINT_MODELS` is every model a
checkpoint may hold: :func:`motionlab.training.load_checkpoint` builds only these classes
(and any registered with :func:`motionlab.training.register_model`), never a class named by
the file itself.
"""
MODELS = {
    "conv_ae": ("motionlab.models.conv_ae", "ConvAutoencoder", "ConvAEConfig"),
    "vae_lstm": ("motionlab.models.vae_lstm", "VAELSTM", "VAELSTMConfig"),
    "lstm": ("motionlab.models.lstm", "MotionLSTM", "LSTMConfig"),
    "glow": ("motionlab.models.glow", "Glow", "GlowConfig"),
    "moglow": ("motionlab.models.moglow", "MoGlow", "MoGlowConfig"),
}

CHECKPOINT_MODELS = {
    **MODELS,
    "vae": ("motionlab.models.vae", "FeatureVAE", "VAEConfig"),
    "dfn": ("motionlab.models.dfn", "DFN", "DFNConfig"),
}
