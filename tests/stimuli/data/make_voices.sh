#!/bin/sh
# Regenerates the test voices of tests/stimuli/test_voices.py: three synthetic speakers of
# varied pitch and rate, 16 kHz mono 16-bit WAV, a few seconds each.
#
#   sh tests/stimuli/data/make_voices.sh     (needs Debian's espeak-ng and sox)
#
# low_male.wav: a low male voice (median F0 near 75 Hz), normal rate;
# high_female.wav: a high female voice (median F0 near 250 Hz), normal rate;
# fast.wav: a mid-pitched voice at about 1.6 times the normal speaking rate.
# espeak-ng writes the same samples for the same version, text and settings; the files are
# committed so that the tests do not depend on it.
set -eu
cd "$(dirname "$0")"
TEXT="Would you really like to come with us tomorrow? We are leaving early, before the sun \
comes up, and the drive takes about three hours. Bring a warm coat, and something to eat."
FAST="Would you really like to come with us tomorrow? We are leaving early, before the sun \
comes up, and the drive takes about three hours. Bring a warm coat, and something to eat on \
the way, because we will not stop until we reach the mountains."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
voice() {  # name, espeak voice, pitch (0-99), words per minute, text
    espeak-ng -v "$2" -p "$3" -s "$4" -w "$tmp/$1.wav" "$5"
    sox "$tmp/$1.wav" -r 16000 -c 1 -b 16 "$1.wav" rate 16000 trim 0 6 norm -3
}
voice low_male en-us+m3 20 165 "$TEXT"
voice high_female en-us+f4 80 170 "$TEXT"
voice fast en-gb+m1 50 280 "$FAST"
