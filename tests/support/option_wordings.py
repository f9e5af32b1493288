"""Option wordings written for the option lexicon's own tuning (tests/test_option_lexicon.py), in
the paraphrase corpus's list format (tests/support/paraphrases.py): one entry per way of wording a
list's claims. They are independent of the corpus's tuning and held-out lists; the corpus's tuning
stems, pairs and layouts are combined with them to read whole questions."""

from __future__ import annotations

OPTION_WORDINGS: dict[str, list[dict[str, str]]] = {
    "option.translation.lateral": [
        {"left": "It sidestepped to the left", "right": "It sidestepped to the right"},
        {"left": "Trucked left", "right": "Trucked right"},
        {"left": "The shooter walked leftward", "right": "The shooter walked rightward"},
        {"left": "It drifted further to the left", "right": "It drifted further to the right"},
        {"left": "Strafing left", "right": "Strafing right"},
    ],
    "option.translation.vertical": [
        {"up": "It rose higher", "down": "It sank lower"},
        {"up": "The camera was hoisted up", "down": "The camera was brought down"},
        {"up": "Boomed up", "down": "Boomed down"},
        {"up": "It gained height", "down": "It lost height"},
        {"up": "Moving upward", "down": "Moving downward"},
    ],
    "option.translation.depth": [
        {"forward": "It advanced toward the scene", "backward": "It retreated from the scene"},
        {"forward": "Walked ahead", "backward": "Walked backward"},
        {"forward": "Came closer to the subject", "backward": "Pulled back"},
        {"forward": "Pushed in", "backward": "Backed off"},
        {"forward": "Approaching", "backward": "Withdrawing"},
    ],
    "option.position": [
        {
            "left": "Located to its left",
            "right": "Located to its right",
            "up": "Located above it",
            "down": "Located below it",
            "forward": "Located in front of it",
            "backward": "Located behind it",
        },
        {
            "left": "On the first camera's left",
            "right": "On the first camera's right",
            "up": "Higher than the first camera",
            "down": "Lower than the first camera",
            "forward": "Ahead of the first camera",
            "backward": "Further back than the first camera",
        },
        {
            "left": "Taken from further left",
            "right": "Taken from further right",
            "up": "Taken from higher up",
            "down": "Taken from lower down",
            "forward": "Taken from closer in",
            "backward": "Taken from farther back",
        },
    ],
    "option.rotation.yaw": [
        {"left": "It swiveled to the left", "right": "It swiveled to the right"},
        {"left": "Glanced left", "right": "Glanced right"},
        {"left": "Its heading moved to the left", "right": "Its heading moved to the right"},
        {"left": "It now faces further left", "right": "It now faces further right"},
        {"left": "Rotated left about the vertical axis", "right": "Rotated right about the vertical axis"},
    ],
    "option.rotation.pitch": [
        {"up": "It pitched upward", "down": "It pitched downward"},
        {"up": "Looked up toward the ceiling", "down": "Looked down toward the floor"},
        {"up": "Aimed higher", "down": "Aimed lower"},
        {"up": "Its line of sight rose", "down": "Its line of sight fell"},
        {"up": "Craned upward", "down": "Angled downward"},
    ],
    "option.rotation.roll": [
        {"clockwise": "It rolled clockwise", "counterclockwise": "It rolled counterclockwise"},
        {
            "clockwise": "Spun clockwise about the optical axis",
            "counterclockwise": "Spun anticlockwise about the optical axis",
        },
        {"clockwise": "Banked clockwise", "counterclockwise": "Banked counter-clockwise"},
        {
            "clockwise": "Twisted clockwise about its line of sight",
            "counterclockwise": "Twisted anticlockwise about its line of sight",
        },
    ],
    "option.still": [
        {"still": "It did not budge"},
        {"still": "Stayed in the same place"},
        {"still": "No change at all"},
        {"still": "It did not move or turn"},
    ],
}
