"""Voices the project never saw, synthesised at test time from Debian's espeak-ng and festival:
ten speakers of different pitch (a 60 Hz bass to 250 Hz), rate (115 to 280 words a minute),
language (English, French, German, Spanish) and kind (espeak's formant voices, festival's
diphone voice and its HTS voice, whose intonation is a natural speaker's), 20-45 s each.

Nothing is downloaded: the voices are Debian packages (`make test` installs them). Without
them a test skips on a developer's machine and fails in CI (``CI=true``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

EN = (
    "Would you really like to come with us tomorrow? We are leaving early, before the sun "
    "comes up, and the drive takes about three hours. Bring a warm coat, and something to "
    "eat on the way. Last year we stopped at a little village near the lake, and the bakery "
    "there was wonderful. Do you remember the old man who sold us apples? He told us the "
    "road would be closed, but it was not. This time, I think we should take the northern "
    "route instead, because it is quieter and much more beautiful in the autumn."
)
FR = (
    "Voulez-vous vraiment venir avec nous demain? Nous partons tôt, avant le lever du "
    "soleil, et le trajet dure environ trois heures. Apportez un manteau chaud et quelque "
    "chose à manger pour la route. L'année dernière, nous nous sommes arrêtés dans un petit "
    "village près du lac, et la boulangerie était merveilleuse. Vous souvenez-vous du vieil "
    "homme qui nous a vendu des pommes? Il disait que la route serait fermée, mais elle ne "
    "l'était pas. Cette fois, prenons plutôt la route du nord, plus calme et plus belle."
)
DE = (
    "Möchtest du wirklich morgen mit uns kommen? Wir fahren früh los, noch vor "
    "Sonnenaufgang, und die Fahrt dauert etwa drei Stunden. Bring einen warmen Mantel mit "
    "und etwas zu essen für unterwegs. Letztes Jahr haben wir in einem kleinen Dorf am See "
    "angehalten, und die Bäckerei dort war wunderbar. Erinnerst du dich an den alten Mann, "
    "der uns Äpfel verkauft hat? Er sagte, die Straße sei gesperrt, aber das stimmte nicht."
)
ES = (
    "¿De verdad quieres venir con nosotros mañana? Salimos temprano, antes de que salga el "
    "sol, y el viaje dura unas tres horas. Trae un abrigo y algo para comer en el camino. El "
    "año pasado paramos en un pueblo cerca del lago, y la panadería era maravillosa. "
    "¿Recuerdas al anciano que nos vendió manzanas? Nos dijo que la carretera estaría "
    "cerrada, pero no lo estaba. Esta vez tomemos la ruta del norte, que es más tranquila."
)
#: name -> (engine, voice, espeak pitch 0-99, words per minute, text)
VOICES: dict[str, tuple[str, str, int, int, str]] = {
    "bass": ("espeak-ng", "en-us+m1", 0, 160, EN),
    "low_male": ("espeak-ng", "en-us+m3", 20, 165, EN),
    "high_female": ("espeak-ng", "en-us+f4", 80, 170, EN),
    "fast": ("espeak-ng", "en-gb+m1", 50, 280, EN + " " + EN),
    "slow": ("espeak-ng", "en-us+f2", 60, 115, EN),
    "french": ("espeak-ng", "fr+m2", 40, 160, FR),
    "german": ("espeak-ng", "de+f3", 70, 160, DE),
    "spanish": ("espeak-ng", "es+m4", 35, 175, ES),
    "festival_hts": ("festival", "voice_cmu_us_slt_arctic_hts", 0, 0, EN),
    "festival_diphone": ("festival", "voice_kal_diphone", 0, 0, EN),
}
TOOLS = ("espeak-ng", "text2wave", "sox")


def require_voices() -> None:
    """Skip without the synthesisers; in CI (``CI=true``), fail: `make test` installs them."""
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        message = f"{', '.join(missing)} not installed (Debian: espeak-ng festival sox)"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(message)
        pytest.skip(message)


def synthesize(name: str, folder: Path) -> Path:
    """Voice ``name`` of :data:`VOICES` as a 16 kHz mono 16-bit WAV in ``folder``."""
    engine, voice, pitch, rate, text = VOICES[name]
    raw, out = folder / f"{name}.raw.wav", folder / f"{name}.wav"
    if engine == "espeak-ng":
        cmd = ["espeak-ng", "-v", voice, "-p", str(pitch), "-s", str(rate), "-w", str(raw), text]
        subprocess.run(cmd, check=True, capture_output=True)
    else:
        cmd = ["text2wave", "-eval", f"({voice})", "-o", str(raw)]
        subprocess.run(cmd, input=text.encode(), check=True, capture_output=True)
    sox = ["sox", str(raw), "-r", "16000", "-c", "1", "-b", "16", str(out), "norm", "-3"]
    subprocess.run(sox, check=True, capture_output=True)
    raw.unlink()
    return out
