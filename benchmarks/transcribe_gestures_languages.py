"""Non-English speech: gestures from the audio only vs with the recognised words (markdown out).

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/transcribe_gestures_languages.py [--seeds 2]
                                                  [--threads N] [--json FILE]

No real Japanese, Chinese, Spanish or German speech is stored here, so the clips are eSpeak NG's (three sentences per
language, about 15 s; Chinese is eSpeak's Mandarin spoken from pinyin, which Whisper base identifies as Chinese).
Each clip is transcribed with the default settings (language auto: tiny.en rejects it, Whisper base identifies the
language); the shipped GestureLSM (its default steps, CFG 2) then generates from the audio only and with the
recognised words, same seeds. Statistics (gesturelsm.evaluation.motion_stats, against the shipped speaker's row):
raised share, loudness following, beat consistency, hand spread; means over seeds. The recognised words are handed
to the generator as given word timings, so Chinese and Japanese words (which the pipeline itself does not use for
the gestures, because of this measurement) are measured too.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from _harness import REPO, Rows, json_flag, save_json, set_threads

sys.path.insert(0, str(REPO))

from gesturelsm.align import tts
from gesturelsm.asr.source import automatic_words
from gesturelsm.audio import resample
from gesturelsm.evaluation.motion_stats import SpeechContext, motion_statistics, speaker_reference, stats_body
from gesturelsm.pipeline import GesturePipeline

CLIPS = {
    "ja": ("ja", ["きのう わたしは ともだちと いっしょに えきの ちかくの レストランで ひるごはんを たべました",
                  "そのあと こうえんを さんぽして たくさんの はなを みました",
                  "らいしゅうは やまに のぼって しゃしんを とりたいと おもいます"]),
    "es": ("es", ["ayer por la tarde fuimos al mercado con mi hermana y compramos pan fresco",
                  "después caminamos por el parque y hablamos de nuestros planes para el verano",
                  "la próxima semana queremos viajar a la montaña y sacar muchas fotos"]),
    "de": ("de", ["gestern nachmittag sind wir mit dem fahrrad zum markt gefahren und haben brot gekauft",
                  "danach sind wir durch den park gelaufen und haben über den sommer gesprochen",
                  "nächste woche wollen wir in die berge fahren und viele fotos machen"]),
    # Mandarin from pinyin with tone numbers (eSpeak's `cmn` voice reads hanzi as tone numbers aloud, "men five"; its
    # pinyin voice with the f3 variant is identified as Chinese): 我们昨天下午在公园里散步，天气非常好。/
    # 看到很多孩子在那里跳舞和唱歌。/ 然后我们去市场买了新鲜的面包和苹果。
    "zh": ("cmn-latn-pinyin+f3", [
        "wo3 men5 zuo2 tian1 xia4 wu3 zai4 gong1 yuan2 li3 san4 bu4 tian1 qi4 fei1 chang2 hao3",
        "kan4 dao4 hen3 duo1 hai2 zi5 zai4 na4 li3 tiao4 wu3 he2 chang4 ge1",
        "ran2 hou4 wo3 men5 qu4 shi4 chang3 mai3 le5 xin1 xian1 de5 mian4 bao1 he2 ping2 guo3"]),
}
KEYS = ("raised_share", "loudness_gain", "bc", "hand_spread")


def clip(voice: str, sentences: list[str]) -> np.ndarray:
    parts = []
    for s in sentences:
        syn = tts.synthesize(s.split(), (voice,), 150)[0]
        parts += [np.zeros(8000, np.float32), resample(syn.audio, syn.sr, 16000).astype(np.float32)]
    y = np.concatenate([*parts, np.zeros(8000, np.float32)])
    return (y + 3e-4 * np.random.default_rng(0).standard_normal(len(y))).astype(np.float32)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--languages", nargs="+", default=list(CLIPS))
    ap.add_argument("--threads", type=int, default=None, help="torch's math threads (default: torch's choice)")
    json_flag(ap)
    args = ap.parse_args()
    if args.threads:
        set_threads(args.threads)
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    ref = speaker_reference()
    body = stats_body()
    table = Rows(["language", "clip (s)", "recognised", "transcript", *(f"{k} audio-only / words" for k in KEYS)])
    print(table.header())
    for lang in args.languages:
        voice, sentences = CLIPS[lang]
        y = clip(voice, sentences)
        ctx = SpeechContext.of(y, ref.mean_speed if ref else None)
        audio_only = pipe.prepare_speech(y, 16000, transcribe=False)
        auto = automatic_words(y[: len(audio_only.audio)])
        heard = auto.transcript.words if auto.transcript is not None and auto.transcript.accepted else None
        words = pipe.prepare_speech(y, 16000, words=heard, transcribe=False)
        words.text_mode, words.transcript = auto.text_mode[:90], auto.transcript.text if heard else None
        rows = {}
        for name, speech in (("audio", audio_only), ("words", words)):
            stats = [motion_statistics(pipe.generate(speech, seed=s, method="gesturelsm", output="raw").motion, body,
                                       ctx)
                     for s in range(args.seeds)]
            rows[name] = {k: float(np.nanmean([st[k] for st in stats])) for k in KEYS}
        said = (words.transcript or (auto.warnings[0] if auto.warnings else ""))[:60].replace("|", "/")
        table.add(f"{lang} ({voice})", f"{len(y) / 16000:.1f}", words.text_mode, said,
                  *(f"{rows['audio'][k]:.3f} / {rows['words'][k]:.3f}" for k in KEYS))
        print(table.last(), flush=True)
    save_json(args.json, table)
    if ref:
        print("\nspeaker's row: " + ", ".join(f"{k} {ref.statistics[k]:.3f}" for k in KEYS))


if __name__ == "__main__":
    main()
