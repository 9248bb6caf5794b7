// Small DOM helpers of the player and the live feed, and the stylesheet (player.css, bundled as text).
import css from './player.css' with { type: 'text' };

const STYLE_ID = 'gesturelsm-player-css';

// A new element with attributes (`text` sets its text), appended to `parent` when given.
export function el(tag, attrs = {}, parent = null) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) (k === 'text' ? (e.textContent = v) : e.setAttribute(k, v));
  if (parent) parent.appendChild(e);
  return e;
}

// Add the player's stylesheet to the document once.
export function adoptStyles(doc = document) {
  if (doc.getElementById(STYLE_ID)) return;
  const style = doc.createElement('style');
  style.id = STYLE_ID;
  style.textContent = css;
  doc.head.appendChild(style);
}
