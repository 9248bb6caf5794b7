"""The GENEA Leaderboard's yardstick: submission folders (submission.py, submit.py) and its objective metrics
(metrics.py, leaderboard.py); `gesturelsm genea` (cli.py). docs/GENEA.md."""
