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


def classes(name: str) -> tuple[type, type]:
    """``(model class, config class)`` of the model ``name`` in :data:`MODELS`, imported
    explicitly here (the command line never imports a module by a name it was given)."""
    if name == "conv_ae":
        from .conv_ae import ConvAEConfig as config, ConvAutoencoder as model
    elif name == "vae":
        from .vae import FeatureVAE as model, VAEConfig as config
    elif name == "vae_lstm":
        from .vae_lstm import VAELSTM as model, VAELSTMConfig as config
    elif name == "lstm":
        from .lstm import LSTMConfig as config, MotionLSTM as model
    elif name == "glow":
        from .glow import Glow as model, GlowConfig as config
    elif name == "moglow":
        from .moglow import MoGlow as model, MoGlowConfig as config
    elif name == "dfn":
        from .dfn import DFN as model, DFNConfig as config
    else:
        raise ValueError(f"name: expected one of {', '.join(MODELS)}, got {name!r}")
    return model, config
