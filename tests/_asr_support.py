"""eSpeak NG speech of known sentences for the speech recognition tests (tests/asr, tests/generator)."""
from __future__ import annotations

import difflib

import numpy as np

from gesturelsm.align import tts
from gesturelsm.align.normalize import speak as spoken

SR = 16_000
ENGLISH = "yesterday my sister walked to the market and bought fresh bread apples and a bottle of milk"
GERMAN = ("guten morgen heute möchte ich ihnen erzählen wie wir im letzten sommer mit dem fahrrad durch die "
          "berge gefahren sind")


# Mandarin: eSpeak NG's `cmn` voice reads hanzi as tone numbers said aloud ("men five"), but its pinyin voice speaks
# the syllables with their tones; with the f3 variant Whisper base identifies it as Chinese. One syllable per hanzi.
CHINESE_VOICE = "cmn-latn-pinyin+f3"
CHINESE_PINYIN = ("wo3 men5 zuo2 tian1 xia4 wu3 zai4 gong1 yuan2 li3 san4 bu4 tian1 qi4 fei1 chang2 hao3 kan4 dao4 "
                  "hen3 duo1 hai2 zi5 zai4 na4 li3 tiao4 wu3 he2 chang4 ge1 ran2 hou4 wo3 men5 qu4 shi4 chang3 mai3 "
                  "le5 xin1 xian1 de5 mian4 bao1 he2 ping2 guo3")
CHINESE = "我们昨天下午在公园里散步天气非常好看到很多孩子在那里跳舞和唱歌然后我们去市场买了新鲜的面包和苹果"
# Whisper base writes traditional characters: the ones of this text, as CHINESE writes them
SIMPLIFIED = str.maketrans("們園裡後買麵蘋場鮮氣歡來時", "们园里后买面苹场鲜气欢来时")


def speak_timed(text: str, voice: str) -> tuple[np.ndarray, np.ndarray]:
    """eSpeak NG speech of `text` at 16 kHz with 0.5 s of faint noise on each side, (N,) float32, and the onset
    (seconds) of each of its space-separated words, as eSpeak reports them."""
    from gesturelsm.audio import resample

    syn = tts.synthesize(text.split(), (voice,), 160)[0]
    y = resample(syn.audio, syn.sr, SR)
    pad = np.zeros(SR // 2, np.float32)
    y = np.concatenate([pad, y, pad])
    return (y + 3e-4 * np.random.default_rng(0).standard_normal(len(y))).astype(np.float32), syn.starts + 0.5


def speak(text: str, voice: str) -> np.ndarray:
    """eSpeak NG speech of `text` at 16 kHz with 0.5 s of faint noise on each side, (N,) float32."""
    return speak_timed(text, voice)[0]


def asr_available() -> bool:
    from gesturelsm.asr import available

    return available() and tts.available()


def matched(pred: list[str], ref: list[str]) -> int:
    """How many of the reference words the recognised ones recover, in order (by spoken form)."""
    sm = difflib.SequenceMatcher(a=[spoken(w) for w in pred], b=[spoken(w) for w in ref], autojunk=False)
    return sum(b.size for b in sm.get_matching_blocks())
