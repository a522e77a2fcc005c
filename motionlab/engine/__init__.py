"""Engine code the models run on, kept apart from the papers' files.

* :mod:`motionlab.engine.recurrent`: an LSTM written out forwards and backwards, which
  trains faster on a CPU where only part of the input needs a gradient.
* :mod:`motionlab.engine.stream`: :class:`~motionlab.engine.stream.MoGlowStream`, MoGlow's
  real-time sampler, one frame per call with its weights laid out once.

What each CPU can do (oneDNN's instruction set, native bfloat16) is probed in
:mod:`motionlab.cpu`.
"""
