"""The GENEA Leaderboard's yardstick: submission folders (submission.py, submit.py) and its objective metrics
(metrics.py, leaderboard.py); `gesturelsm genea` (commands/genea.py). docs/GENEA.md."""
