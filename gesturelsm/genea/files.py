"""The files the leaderboard's metrics read beside the motion (leaderboard.py), named without torch so that
`gesturelsm genea --help` names them before any model code loads."""
EMAGE_FILE = "AESKConv_240_100.bin"                 # EMAGE's motion autoencoder, for FGD
MEAN_SPEED_FILE = "mean_vel_smplxflame_30.npy"      # BEAT2's mean joint speeds, for beat alignment
