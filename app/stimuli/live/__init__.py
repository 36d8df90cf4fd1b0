"""Live speech-driven head, gaze and eyelid motion (Le, Ma & Deng 2012, sec. 5-7).

- :mod:`.mixture`: Gaussian mixtures and their per-frame 1-D slices (sec. 5.1, eq. 2).
- :mod:`.head`: kinematic features (eq. 1), the five-GMM model and gradient ascent (eq. 3-5).
- :mod:`.gaze`: NDCCA gaze (sec. 6, eq. 8-15).
- :mod:`.eyelids`: gaze-evoked lids by NNLS and log-normal blinks (sec. 7, eq. 16-19).
- :mod:`.inputs`, :mod:`.audio`: the speech input, from features or a stream of audio blocks.
- :mod:`.model`: the model and its training; :mod:`.modelfile`: its ``.npz`` file;
  :mod:`.stream`: the per-frame generator.
- :mod:`.condition`: the ``live_gmm`` prosody condition.

The submodules are imported on use, so importing this package stays cheap.
"""
