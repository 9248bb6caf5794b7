"""The page's own stylesheet (passed to `Blocks.launch` by `demo.Demo`) and the browser-side check of its tables.

Tables of numbers fit their column or scroll inside it (a wrapper with `overflow-x: auto`: `SCROLL`), and their
headings break only between words: Gradio's Dataframe (`#timings`) breaks header text anywhere by default, which
turned "features" into "featur / es". `TABLES_JS` measures both in a page (tests/webapp/test_layout_browser.py,
scripts/page_screenshots.py).
"""
from __future__ import annotations

from gesturelsm.serve.request import TIMING_COLUMNS

# Shown by a transcript box when speech is uploaded or recorded while the box holds words the visitor typed (words
# the page recognised for earlier speech are cleared instead, ui.py): typed words are never used silently for other
# speech.
TYPED_NOTE = ("The transcript box holds words typed before this speech was chosen: they are timed against this "
              "speech. Clear the box to have this speech transcribed automatically.")

TABLE_BOXES = ("#timings", "#motion-stats-box", "#sweep-table-box")

# The timing table's columns (`#timings`: the method, then each stage of TIMING_COLUMNS): the labels
# ("whole request, 5.1 s of speech, ...") wrap in a narrow first column and the stages take what their headings need,
# so the whole table fits the 800 px results column of a 1280 px window instead of scrolling the stages out of sight.
TIMING_WIDTHS = ["136px"] + ["auto"] * (len(TIMING_COLUMNS) - 1)

# the wrapper of a wide HTML table: it scrolls sideways inside its column instead of running off the page
SCROLL = 'class="gesturelsm-scroll" style="overflow-x: auto; max-width: 100%;"'

PAGE_CSS = """
/* tables of numbers: compact, headings break between words only (never "featur / es"), wide ones scroll inside */
#timings table, #motion-stats-box table, #sweep-table-box table { font-size: 13px; }
#timings th, #timings td, #timings th *, #timings td * { font-size: 13px !important; }
#timings th, #timings td { padding: 0 !important; }          /* the cell's own box pads: 4px 6px below */
#timings th .cell-wrap, #timings td .cell-wrap { padding: 4px 6px !important; font-family: var(--font) !important; }
#timings .cell-menu-button { display: none !important; }  /* the read-only table's column menu took a heading's room */
#timings .header-content { min-width: 0 !important; gap: 0 !important; }
#timings th, #timings th * { white-space: normal !important; }   /* between words: "real-time / factor" */
#timings th, #timings th *, #motion-stats-box th, #motion-stats-box th *, #sweep-table-box th, #sweep-table-box th * {
  word-break: normal !important; overflow-wrap: normal !important; hyphens: manual !important;
}
#motion-stats-box td, #motion-stats-box th, #sweep-table-box td, #sweep-table-box th { padding: 4px 6px; }
#motion-stats-box th, #sweep-table-box th { vertical-align: bottom; }
#motion-stats-box td, #sweep-table-box td { white-space: nowrap; }
#motion-stats-box td:first-child, #sweep-table-box td:first-child { white-space: normal; min-width: 7em; }
.gesturelsm-scroll { overflow-x: auto; max-width: 100%; }
#generate-status { min-height: 1.5em; }
/* a box being computed keeps Gradio's accent border, without its endless pulse: every pulse frame repainted the boxes,
   which a browser drawing without a GPU does on the CPU for the whole generation (docs/BENCHMARKS.md) */
.wrap.generating { animation: none !important; }
#transcript-note { color: #9a4a00; }
"""

# For each table under the given boxes: whether it is cut (wider than a box around it that does not scroll), scrolls
# inside an `overflow-x: auto` box, or fits; and the heading words that are broken across lines (a word of a heading
# cell whose text spans more than one line box), with the cell's text.
TABLES_JS = """(boxes) => boxes.flatMap((sel) => [...document.querySelectorAll(`${sel} table`)]
  .filter((t) => t.getClientRects().length > 0).map((t) => {
    const box = document.querySelector(sel);
    let cut = false, scrolls = false;
    for (let e = t.parentElement; e; e = e.parentElement) {
        const s = getComputedStyle(e), wide = e.scrollWidth > e.clientWidth + 1;
        if (['auto', 'scroll'].includes(s.overflowX)) { scrolls = wide; if (wide) break; }
        else if (wide && s.overflowX !== 'visible') { cut = true; break; }
        if (e === box) {
            const r = box.getBoundingClientRect(), tr = t.getBoundingClientRect();
            if (!scrolls && tr.right > r.right + 1) cut = true;
            break;
        }
    }
    const broken = [];
    for (const th of t.querySelectorAll('th')) {
        const walker = document.createTreeWalker(th, NodeFilter.SHOW_TEXT);
        for (let n = walker.nextNode(); n; n = walker.nextNode()) {
            const re = /[^\\s-]+-?/g;
            for (let m = re.exec(n.data); m; m = re.exec(n.data)) {
                const range = document.createRange();
                range.setStart(n, m.index); range.setEnd(n, m.index + m[0].length);
                const rects = [...range.getClientRects()].filter((r) => r.width > 0);
                const tops = new Set(rects.map((r) => Math.round(r.top)));
                const edge = th.getBoundingClientRect();        // a word running past its cell is clipped there
                const out = rects.some((r) => r.right > edge.right + 1 || r.left < edge.left - 1);
                if (tops.size > 1 || out) broken.push(`${m[0]} (in "${th.innerText.replace(/\\s+/g, ' ')}")`);
            }
        }
    }
    return {box: sel, cut, scrolls, broken, width: Math.round(t.getBoundingClientRect().width)};
}))"""
