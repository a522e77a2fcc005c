"""One file per model, each readable top to bottom beside its paper.

:data:`MODELS` maps the names the command line (``python -m motionlab.train NAME``) knows
to ``(module, model class, config class)``.
"""
MODELS = {
    "conv_ae": ("motionlab.models.conv_ae", "ConvAutoencoder", "ConvAEConfig"),
    "vae": ("motionlab.models.vae", "FeatureVAE", "VAEConfig"),          # on a conv_ae's features
    "vae_lstm": ("motionlab.models.vae_lstm", "VAELSTM", "VAELSTMConfig"),
    "lstm": ("motionlab.models.lstm", "MotionLSTM", "LSTMConfig"),
    "glow": ("motionlab.models.glow", "Glow", "GlowConfig"),
    "moglow": ("motionlab.models.moglow", "MoGlow", "MoGlowConfig"),
    "dfn": ("motionlab.models.dfn", "DFN", "DFNConfig"),                # trained in stages
}
