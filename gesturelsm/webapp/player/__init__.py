"""The page's in-browser motion player, both halves in one place: its JavaScript (`src/`: three.js ES modules and
player.css, pinned in package.json / package-lock.json), bundled offline by npm + esbuild into `dist/player.js`
(scripts/setup.sh; no CDN), and its Gradio side (`component.py`: the element the bundle mounts on, and the files and
payload it loads). Importing this package loads nothing."""
