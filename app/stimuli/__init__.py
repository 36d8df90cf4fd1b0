"""Stimuli: speech features, MPEG-4 FAP motion tracks, .fap/.csv files and prosody conditions.

No Flask here. Thesis sec. 3.2 (motion capture to FAPs) and sec. 4.3 (the four conditions).
"""
