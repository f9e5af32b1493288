"""The motion lexicon: a table of words to meanings, and the reading of a phrase into a claim.

Every word or fixed phrase people use for a camera's motion is one row of `LEXICON`: a pattern (on
lower-cased text, punctuation and hyphens as spaces) and its meaning (a `Sense` of one kind):

- ``step``: a verb of translation, with the way it carries when it carries one ("climb" is up,
  "withdraw" is backward, "sidestep" none); ``weak`` for the everyday verbs ("move", "go") that
  people also use for turning, so a stem with them does not fix the quantity;
- ``aim``: a verb of rotation whose axis comes from its direction ("turn left" is a yaw, "turn
  upward" a pitch); ``yaw``, ``pitch``, ``roll``: verbs of one axis ("pan", "tilt", "spin");
- ``place``: a verb of position ("located", "taken from", "sits");
- ``way``: a direction (left, right, up, down, forward, backward), ``sense``: clockwise or not;
- ``still``: no motion; ``not``: negation of the next verb;
- ``filler``: words that only grade or frame a direction ("further to the left", "right behind
  it", "ended up", "from the photographer's point of view");
- ``zoom``, ``return``, ``source``: words that state no camera claim (a zoom is the focal length;
  "went back to" a place and "came in from the left" name no way the camera went).

Verbs are written by their base form and inflected by `_verb` (climb/climbs/climbed/climbing,
step/stepped, slide/slid, withdraw/withdrew), so a row is a word, not a list of its forms.

`read_phrase(text)` turns an option into one claim (shared/questions/claims.py) by composition:
tokens in the order they come, each verb opening a part that the following directions belong to
("moved left and turned right" is two parts; "stepped back, away from the scene" is one step). Words
outside the table leave the phrase `Unread`: never guessed. Also unread, with the reason, is what
could be read as the wrong claim: opposite directions in one part ("back and forth"), a direction
that does not fit its verb's axis ("tilted left"), a negated direction ("did not turn left"), the
scene or picture as the subject ("the scene slid left": content moves opposite to the camera), a
view moved by a step verb ("the view shifted left": a pan does that too), and the first camera as
the subject (its place relative to the second is the reverse). `views_named` gives the photos an
option names by number, for the reading to check against the pair. Hedges ("it seems to have",
"apparently") mean nothing of their own, but one that opens a clause ("it looks like the scene
moved") gives it its own subject, checked as above. `kinds_named` gives the kinds an unread option's
verbs name, for the quantity a question asks (never for a claim).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from shared.questions.claims import (
    Bare,
    Claim,
    Compound,
    Position,
    Rotation,
    Still,
    Target,
    Translation,
    Unread,
    Way,
    claim_kinds,
)

_V = r"(?:s|es|ed|d|ing|ion|ment)?"  # a verb's inflections


@dataclass(frozen=True)
class Sense:
    """One meaning: `kind` is step / weak / aim / yaw / pitch / roll / place / way / sense / still / not."""

    kind: str
    value: str | None = None


_IRREGULAR = {
    "bring": ("brought",),
    "come": ("came",),
    "fall": ("fell", "fallen"),
    "get": ("got", "gotten"),
    "go": ("went", "gone", "goes"),
    "glide": (),
    "rise": ("rose", "risen"),
    "sink": ("sank", "sunk"),
    "swing": ("swung",),
    "spin": ("spun",),
    "slide": ("slid",),
    "withdraw": ("withdrew", "withdrawn"),
    "draw": ("drew", "drawn"),
    "take": ("took", "taken"),
    "creep": ("crept",),
}
# A final consonant after one short vowel may double: step/stepped, pan/panned, sidestep/sidestepping
# (both spellings are kept: pivoted, travelled/traveled).
_DOUBLED = re.compile(r"(?:(?<![aeiou])|(?<=qu))[aeiou][bdglmnprt]$")


def _verb(*bases: str) -> str:
    """Every inflection of each base verb, as one pattern: climb/climbs/climbed/climbing,
    step/stepped/stepping, slide/slides/slid/sliding, carry/carried, plus the irregular forms."""
    forms: list[str] = []
    for base in bases:
        stem = base[:-1] if base.endswith("e") else base
        double = base + base[-1] if _DOUBLED.search(base) else stem
        ies = base[:-1] + "ie" if base.endswith("y") and base[-2] not in "aeiou" else None
        forms += [base, double + "ing", stem + "ing"]
        if ies:
            forms += [ies + "s", ies + "d"]
        else:
            forms += [base + ("es" if base.endswith(("s", "sh", "ch", "x")) else "s")]
            forms += [base + "d" if base.endswith("e") else base + "ed", double + "ed"]
        forms += list(_IRREGULAR.get(base, ()))
    return "|".join(sorted(set(forms), key=len, reverse=True))


# "... the direction it was facing", "... what the camera was looking at"
_FACING = (
    r"(?:it|the camera) (?:was |is )?(?:facing|faced|faces|pointing|pointed|points|looking|looked|looks|"
    r"aimed|aiming)(?: at)?"
)
_KIND_NOUN = r"(?: (?:rotation|movement|motion|turn|change|shift))?"
_STEP = "step"
_ROWS: tuple[tuple[str, Sense], ...] = (
    # ---- still: no motion at all (before the verbs, so "did not move" is read whole)
    (r"(?:held|kept|keep|keeps|maintained|kept to|stayed at) (?:its|the same|the) (?:position|place|"
     r"pose|spot|location)"
     r"(?: and (?:its )?(?:aim|orientation|heading|direction|angle))?", Sense("still")),
    (r"(?:(?:was|were|is|are|been|both|all) )*(?:taken|shot|captured|photographed|snapped) (?:from|at) "
     r"(?:the |one and the )?(?:same|identical) "
     r"(?:position|place|spot|location|point|viewpoint|vantage point)|"
     r"(?:the )?same (?:position|place|spot|location)(?: and)? (?:the )?same "
     r"(?:direction|orientation|heading|"
     r"angle|aim)", Sense("still")),
    (r"(?:stay|stayed|stays|staying|kept|keep|stood|stand|held|hold|remained|remain|remains|sat|sit|sits)\s+"
     r"(?:(?:completely|perfectly|exactly|precisely|right|roughly|approximately|basically|essentially|"
     r"more or less|almost|nearly|virtually|practically)\s+)?"
     r"(?:still|put|stationary|motionless|fixed|steady|in place|where it (?:was|stood|had been)|at rest|"
     r"as it was|its ground|in one (?:spot|place|position|location)|"
     r"(?:at|in) (?:the same|its|its original|the original|its initial|the initial|its previous|"
     r"the previous|its starting|the starting) (?:spot|place|position|point|location))", Sense("still")),
    (r"(?:its |the )?(?:pose|position|place|location|viewpoint)(?: and (?:its )?(?:orientation|heading|"
     r"direction|aim|angle))? (?:did not|didn t|never|has not|hasn t) (?:change|move|shift)|"
     r"neither (?:its )?(?:position|location|place) nor (?:its )?(?:orientation|heading|direction|aim|angle) "
     r"(?:changed|moved|shifted)|no (?:motion|movement|change) (?:occurred|took place|happened)|"
     r"(?:the )?same (?:position|place|spot|location|pose) and (?:orientation|heading|direction|aim|angle)|"
     r"(?:did not|didn t|never) (?:move|shift|translate) (?:or|nor) (?:turn|rotate)|"
     r"(?:both )?(?:its )?(?:position|location|pose) and (?:its )?(?:orientation|heading|direction|aim|angle)"
     r"(?: (?:were|are|remained|stayed))? (?:unchanged|the same|identical)|"
     r"no (?:change|difference) in (?:its |the )?(?:camera s |camera )?(?:pose|position|location)|"
     r"(?:its |the )?(?:camera s |camera )?pose (?:is|was|remained|stayed) (?:identical|the same|unchanged)|"
     r"nothing (?:changed|moved|happened)", Sense("still")),
    # a negated "either": neither a step nor a turn ("did not change position or direction"), and
    # stillness said with a grade or as a pose ("perfectly still", "fixed in place", "identical pose")
    (r"(?:did not|didn t|never|was not|wasn t|has not|hasn t) (?:change (?:its |the )?(?:position|location|"
     r"place)|move|moved|shift|shifted|translate|translated) (?:or|nor) (?:(?:change )?(?:its |the )?"
     r"(?:direction|orientation|heading|aim|angle)|turn|turned|rotate|rotated)|"
     r"no (?:change|difference) in (?:its |the )?(?:position|location|place|pose) (?:or|nor|and) "
     r"(?:its |the )?(?:direction|orientation|heading|aim|angle)|"
     r"(?:perfectly|completely|totally|entirely|absolutely|dead|stock|quite) still|"
     r"fixed in (?:place|position)|identical (?:pose|position|place|spot|location|viewpoint)",
     Sense("still")),
    (r"(?:did not|didn t|does not|doesn t|never)\s+(?:move|budge|change position|"
     r"shift)\b(?!\s+(?:left|right|up|down|forward|back))",
     Sense("still")),
    (r"no (?:motion|movement|translation|displacement) (?:or|nor|and no|and) (?:rotation|turning|turn)|"
     r"no (?:rotation|turning|turn) (?:or|nor|and no|and) (?:motion|movement|translation|displacement)|"
     r"at rest|" + _verb("rest") + r"(?= in place| still| where)|unrotated|"
     r"(?:did not|didn t|never) change (?:its |the )?(?:pose|position|place|location|spot)|"
     r"neither moved nor (?:turned|rotated)|no (?:camera )?(?:motion|movement|change)(?: at all)?|not moving|"
     r"stationary|motionless|unmoved|static|unchanged|(?:the )?same (?:position|place|spot|location|"
     r"pose|point|viewpoint)|"
     r"in place|did not budge|no displacement", Sense("still")),
    # ---- where a motion came from ("came in from the left"): the opposite of where it went
    (r"from (?:the |its )?(?:left|right|above|below|behind|front|back|top|bottom|"
     r"left hand side|right hand side|left side|right side)", Sense("source")),
    # ---- a zoom changes the focal length, not the camera's place: no claim the lexicon reads
    (_verb("zoom") + r"(?: in| out)?", Sense("zoom")),
    # ---- looking around is a scan of the room, not a turn to one side or about face
    (r"(?:" + _verb("look", "glance", "peer", "peek", "gaze") + r") (?:all )?(?:a)?round(?! to\b)",
     Sense("survey")),
    # ---- a high or low camera angle is where the camera looks from and toward, not one motion
    (r"(?:high|low|higher|lower|bird s eye|worm s eye|eye level)(?: camera)? angle", Sense("camera_angle")),
    # ---- a return to where it was ("went back to", "came back"): no direction of its own
    (r"back to|(?:came|come|comes|coming) back|turn(?:ed|s|ing)? back|" + _verb("return"), Sense("return")),
    # ---- words that only grade or place a direction: "right behind it", "further to the left",
    # "ended up to the right", "glided over to the right"
    (r"right(?= (?:above|below|behind|in front|ahead|over|under|beneath|underneath|beside|next)\b)|"
     r"(?:further|farther)(?= (?:out |over |off )?(?:to |toward |towards |on )?(?:the |its |their )?"
     r"(?:left|right|up|upward|"
     r"down|downward|forward|ahead|in)\b)|"
     r"point of view|perspective|(?:as )?(?:seen|viewed) (?:from|by) (?:the |its )?(?:\w+ )?"
     r"(?:camera|image|photo|picture|view|shot|photographer|shooter|viewer)(?: s (?:side|position|place))?|"
     r"as (?:the |it )?(?:camera |photographer |shooter |viewer )?(?:sees|saw|see) (?:it|them)|"
     r"with respect to|next to|beside|alongside|steeply|"
     r"(?:when |as )?(?:seen|viewed|looking) from behind(?: the camera| the lens)?|"
     r"(?:when |while )?looking (?:through|along) the (?:lens|viewfinder|camera)|"
     # notes on whose axes or from where the sense is judged: "in image 1's coordinates", "as seen
     # through the viewfinder", "judged from behind the camera"
     r"(?:as )?(?:seen|viewed|judged|observed|counted) (?:through|from|along|in) (?:the |its )?"
     r"(?:viewfinder|lens|eyepiece|screen|back of the camera|behind(?: the camera| the lens)?)|"
     r"(?:in|using|with respect to|relative to|according to) (?:the )?(?:(?:first|reference|original|initial|"
     r"earlier|starting)(?: (?:image|photo|picture|view|shot|frame|camera|snapshot))?|(?:image|photo|picture|"
     r"view|shot|frame|camera|snapshot) \d+|camera|photographer|shooter)(?: s)? (?:own )?(?:coordinates|"
     r"coordinate (?:frame|system)|axes|frame of reference|reference frame)|"
     r"in (?:terms of|the direction of)(?= (?:the |its )?(?:left|right))|"
     r"(?:end|ends|ended|ending) up|wound up|came to rest|"
     r"(?:end|finish|land|settl|arriv)(?:ed|es|s|ing)?(?= (?:up |out )?(?:on|at|to|in|further|farther|more|"
     r"higher|lower|slightly|a|somewhat|just|above|below|behind|ahead)\b)|"
     r"dead(?= ahead)|well(?= (?:to|above|below|behind|in front|ahead|back|over|under|off)\b)|"
     r"(?:by|through) (?:a |an )?(?:\w+ )?angle(?: of)?|"
     r"(?:its|the camera s|his|her|their|the photographer s|the shooter s) head|"
     r"over(?= to\b)|(?:a)?round(?= to (?:the |its )?(?:left|right)\b)|"
     r"lateral(?:ly)?|vertical(?:ly)?|horizontal(?:ly)?|"
     r"where (?:the )?(?:first |earlier |other |previous |reference )?(?:image|photo|picture|view|shot|frame|"
     r"camera|snapshot)(?: \w+)? (?:was|is|had been) (?:taken|shot|captured|located|positioned)|"
     r"(?:a |some )?(?:long|short|little|small|good|fair|tiny) (?:way|distance)|some distance|"
     r"(?:made|make|makes|making|took|take|takes|taking) (?:a|an|one)(?= (?:\w+ )?(?:\w+ )?(?:turn|move|"
     r"step|shift|pan|tilt|roll|rotation|movement)\b)|"
     r"away from (?:the |its )?(?:first|original|initial|previous|earlier|starting|old|former) "
     r"(?:position|place|spot|location|point|pose|viewpoint)|"
     r"(?:the )?(?:person|one|someone) (?:holding|carrying|with) the camera|"
     r"at all|than (?:before|previously|earlier|"
     r"originally|it was|at first)|vantage point|view ?point|standpoint|"
     # notes on which photos are compared: "between the two shots", "from where it started"
     r"between (?:the |these |those )?(?:two |both )?(?:shots|photos|pictures|images|views|frames|snapshots)|"
     r"from one (?:shot|photo|picture|image|view|frame|snapshot) to the (?:next|other|second)|"
     r"judging (?:by|from) (?:the )?(?:two |both )?(?:shots|photos|pictures|images|views|frames)|"
     r"since the (?:first|earlier|previous|last) (?:shot|photo|picture|image|view|frame|snapshot)|"
     r"(?:relative to |compared (?:with |to )|from )?where (?:it|the camera|the photographer|we|i|they) "
     r"(?:started|was|had been|stood|began|were|first stood)(?: before)?|"
     r"for the (?:second|later|latter|last|final|new|next|other) (?:image|photo|picture|view|shot|frame|"
     r"snapshot)|"
     # "from a point further left": a point is a place here, not a way of aiming
     r"(?:a|another|one|some|that|this) point(?! (?:at|toward|towards|up|down|left|right)\b)|"
     r"(?:(?<=higher )|(?<=lower )|(?<=closer )|(?<=nearer )|(?<=further )|(?<=farther ))point|"
     # "it stayed put and kept its aim": the aim kept adds no claim of its own
     r"(?:and )?(?:kept|keeping|maintained|held) (?:its|the same|the) (?:aim|direction|heading|orientation|"
     r"angle)(?= and|$)|"
     # "taken from the same spot with the same aim": the aim kept adds no claim
     r"(?:with|and|facing|keeping|while keeping) (?:the |its )?same "
     r"(?:aim|direction|orientation|heading|angle|way)", Sense("filler")),
    # ---- hedges ("it seems to have", "it looks as if", "apparently"): no meaning of their own, but what
    # follows "it looks like" is a clause with its own subject ("it looks like the scene moved left")
    (r"(?:it |the camera )?(?:seem|appear)(?:s|ed)?"
     r"(?: to(?: have)?(?: been)?| as if| as though| that| like)?|"
     r"(?:it |the camera )?look(?:s|ed)? (?:like|as if|as though)|"
     r"(?:most |very |quite )?(?:probably|likely|apparently|perhaps|maybe|possibly|presumably|evidently|"
     r"seemingly|clearly|obviously)|(?:i|we) (?:think|guess|believe|would say)", Sense("hedge")),
    # ---- negation of the next verb
    (r"did not|didn t|does not|doesn t|not|without|no|never|neither|nor|zero", Sense("not")),
    # ---- two claims offered as one ("backward or to the left"): the option says two things
    (r"or|either", Sense("or")),
    # ---- the camera's orientation as a noun: "its aim rose", "the heading swung left"
    (r"^(?:its|the camera s) direction(?! (?:of|it|the camera)\b)|"
     r"(?:its|the|camera s|the camera s) (?:aim|heading|bearing|gaze|line of sight|"
     r"(?:view|viewing|facing|pointing|looking) direction|direction of (?:view|gaze|sight)|"
     r"orientation|optical axis)", Sense("aimnoun")),
    # ---- a step along the way the camera looks is forward, against it backward
    (r"(?:in|toward|towards) (?:the (?:same )?direction|what) " + _FACING, Sense("way", "forward")),
    (r"(?:(?:opposite|contrary) (?:to )?|away from )(?:the direction|what) " + _FACING,
     Sense("way", "backward")),
    (r"along (?:its |the )?(?:(?:viewing|view|facing|pointing|looking) direction|line of sight|"
     r"optical axis|direction (?:it|the camera) (?:faced|faces|was facing|is facing|pointed|points))",
     Sense("way", "forward")),
    (r"against (?:its |the )?(?:(?:viewing|view|facing|pointing|looking) direction|line of sight|"
     r"optical axis)",
     Sense("way", "backward")),
    # ---- a yaw's sense seen from above (clockwise from above is a turn right)
    (r"(?:as )?(?:seen|viewed|looking down) from (?:above|overhead)|(?:as )?seen from the top",
     Sense("axis", "yaw_from_above")),
    (r"(?:about|around|round|along|on) (?:its |the )?(?:(?:lens s |lens |optical |viewing |view |forward |"
     r"camera s )?axis|line of sight|(?:viewing|view|facing|pointing|looking|forward) direction)",
     Sense("axis", "roll")),
    (r"(?:about|around|round|on) (?:its |the |a )?vertical axis", Sense("axis", "yaw")),
    (r"(?:about|around|round) (?:its |the )?(?:lens|optical center|optical centre)", Sense("axis", "roll")),
    (r"(?:in|within) (?:the )?(?:image|frame|picture|photo) plane|in plane|"
     r"(?:about|around|round|on) (?:its |the )?depth axis",
     Sense("axis", "roll")),
    # ---- rotation about the optical axis (before the verbs that share words with it)
    (r"(?:rotat\w*|turn\w*|spun|spin\w*|twist\w*)\s+(?:about|around|round|on)\s+(?:its\s+|the\s+)?"
     r"(?:lens|optical|viewing|view|camera s|line of sight|forward)\s*(?:axis)?", Sense("roll")),
    # "a yaw rotation", "tilt movement": the noun after an axis word adds nothing
    (r"(?:roll\w*|spin\w*|spun|cant\w*|bank\w*|twist\w*|barrel roll|dutch(?: angle| tilt)?|"
     r"lean(?:s|ed|ing)?|leant)" + _KIND_NOUN,
     Sense("roll")),
    (r"counter clockwise|counterclockwise|anticlockwise|anti clockwise|"
     r"ccw", Sense("sense", "counterclockwise")),
    (r"clockwise|cw", Sense("sense", "clockwise")),
    # ---- rotation
    (r"(?:its |the |camera s |the camera s |camera )?(?:position|location|height|elevation|altitude)",
     Sense("placenoun")),
    (r"(?:its |the |camera s |the camera s )?nose|"
     r"(?:its|the|camera s|the camera s) (?:viewing |camera |tilt )?angle|"
     r"(?:the )?direction of the camera(?! s (?:movement|motion|travel|displacement|translation|step|shift|"
     r"walk|path|position|location)\b)|"
     r"(?:the )?camera (?:direction|heading|orientation)", Sense("aimnoun")),
    (r"(?:tilt\w*|pitch\w*|nod\w*|cran\w*|tip(?:s|ped|ping)?|angl(?:e|ed|es|ing)(?: the (?:view|camera|"
     r"shot|lens))?)" + _KIND_NOUN,
     Sense("pitch")),
    (r"(?:yaw\w*|veer\w*|pan(?:s|ned|ning)?|swivel\w*|swung|swing\w*|pivot\w*|look(?:ed|s|ing)? aside)"
     + _KIND_NOUN,
     Sense("yaw")),
    (r"(?:spun|spin(?:s|ning)?|whip(?:s|ped|ping)?|swung|swing(?:s|ing)?|swivel\w*|pivot\w*|"
     r"wheel(?:s|ed|ing)?) "
     r"(?:a)?round(?! (?:to|toward|towards|its|the|a|about|on)\b)|"
     r"u turn|about face|about turn|turn(?:ed|s|ing)? (?:a|the) other way|"
     r"face(?:d)? the opposite (?:way|direction)",
     Sense("aim", "around")),
    (r"turn\w*|rotat\w*|point\w*|aim\w*|fac(?:e|ed|es|ing)|orient\w*|look\w*|gaz\w*|view direction|"
     + _verb("glance", "peer", "peek", "revolve", "twirl") + "|"
     r"direction (?:it|the camera) (?:faces|faced|points|pointed)|heading", Sense("aim")),
    # ---- position of one camera relative to another
    (r"locat(?:ed|es|ing)|position(?:ed|ing)|placed|situat(?:ed|es|ing)|lies|lay|lying|sits|sat|stands|stood|"
     r"(?:was |were |is )?taken from|shot from|captured from|set up|"
     r"(?:(?<=image )|(?<=photo )|(?<=picture )|(?<=view )|(?<=snapshot ))(?:\d+ )?(?:taken|shot|captured)|"
     r"(?:was|were|is|been) (?:taken|shot|captured|snapped|photographed)|"
     + _verb("set", "perch", "mount", "station", "stand", "sit") + "|"
     r"held(?= (?:higher|lower|further|farther|more|up|down|to|above|below|slightly|a bit|somewhat)\b)",
     Sense("place")),
    # ---- a step toward an edge of the photo: the frame's own directions
    (r"(?:toward|towards|to) (?:the )?(?:frame|image|picture|photo|view)(?: s)? (?:upper|"
     r"top) edge", Sense(_STEP, "up")),
    (r"(?:toward|towards|to) (?:the )?(?:frame|image|picture|photo|view)(?: s)? (?:lower|bottom) edge",
     Sense(_STEP, "down")),
    (r"(?:toward|towards|to) (?:the )?(?:frame|image|picture|photo|"
     r"view)(?: s)? left edge", Sense(_STEP, "left")),
    (r"(?:toward|towards|to) (?:the )?(?:frame|image|picture|photo|"
     r"view)(?: s)? right edge", Sense(_STEP, "right")),
    # ---- translation verbs that carry their way
    (_verb("sidestep", "strafe", "truck", "crab", "sidle", "shuffle", "hop", "shimmy", "creep", "wander",
           "mosey", "bob", "duck", "stroll", "amble", "march", "pace", "roam", "ease", "surge"),
     Sense(_STEP)),
    # "pulled up" is stopping, "pushed up" unclear: pushing and pulling carry only the other ways
    ("(?:" + _verb("push", "pull") + r")(?! (?:up|down|over)\b)", Sense(_STEP)),
    (r"climb\w*|ascen\w*|rose|ris(?:e|en|es|ing)|rais\w*|lift\w*|elevat\w*|"
     r"gain(?:ed|s|ing)? (?:(?:in|of) |some |a little |a bit of |a bit |more )?(?:height|altitude|elevation)|"
     r"(?:at|to) a (?:greater|higher|larger) (?:height|elevation|level|altitude)|"
     r"(?:from|at) a higher|higher up|"
     r"(?:pedestal(?:l?ed|l?ing|s)?|ped(?:ded|ding|s)?) up|boom(?:ed|ing|s)? up|" + _verb("hoist"),
     Sense(_STEP, "up")),
    (r"descen\w*|sank|sink\w*|sunk|dropp?\w*|lower(?:ed|ing|s)|"
     r"los(?:t|es|ing|s) (?:(?:in|of) |some |a little |a bit of |a bit )?(?:height|altitude|elevation)|"
     r"(?:at|to) a (?:lower|lesser|smaller|reduced) (?:height|elevation|level|altitude)|"
     r"(?:from|at) a lower|lower down|(?:pedestal(?:l?ed|l?ing|s)?|ped(?:ded|ding|s)?) down|"
     r"boom(?:ed|ing|s)? down|hunker(?:ed|s|ing)? down|"
     + _verb("fall", "crouch", "stoop", "squat", "kneel") + "|knelt",
     Sense(_STEP, "down")),
    (r"(?:clos|reduc|shorten|narrow|shrink|shrank|cut)\w* (?:its |the )?distance"
     r"(?: (?:to|from) (?:the )?(?:scene|subject))?|"
     r"(?:crept|creep\w*|sneak\w*|snuck|came|come|walk\w*|mov\w*) up (?:on|to) (?:the |it\b)|"
     r"advanc\w*|proceed\w*|approach\w*|push(?:ed|es|ing)? in|dolly(?:ing)? in|dollied in|"
     r"clos(?:er|ed in)|nearer|deeper into|came in|"
     rf"(?:{_verb('move', 'step', 'walk', 'lean')}) in(?: closer| nearer)?(?=$| and\b| then\b| toward)",
     Sense(_STEP, "forward")),
    (r"fell back|fall(?:s|ing)? back|(?:increas|widen|grow|lengthen)\w* (?:its |the )?distance"
     r"(?: (?:to|from) (?:the )?(?:scene|subject))?|"
     r"withdr\w*|retreat\w*|" + _verb("reverse") + "|"
     r"reced\w*|back(?:ed|s|ing)? (?:up|off|away|out)|step(?:ped|s|ping)? back|"
     r"pull(?:ed|s|ing)? (?:back|out|away)|dolly(?:ing)? out|dollied out|"
     r"(?:farther|further)(?: away| back| off)?|away from|more distant",
     Sense(_STEP, "backward")),
    # ---- the camera's height said as a quantity that grew or shrank
    (r"(?:its |the |camera s |the camera s )?(?:height|elevation|altitude) (?:"
     + _verb("increase", "grow") + r"|grew|grown)", Sense(_STEP, "up")),
    (r"(?:its |the |camera s |the camera s )?(?:height|elevation|altitude) (?:"
     + _verb("decrease", "shrink", "reduce") + r"|shrank|shrunk)", Sense(_STEP, "down")),
    (r"sideways|sidewise|laterally|shift\w*|slid\w*|translat\w*|displac\w*|relocat\w*|reposition\w*|"
     r"glid\w*|drift\w*|step\w*|walk\w*|"
     r"dolly|dollied|carr(?:y|ied)|travel\w*|head(?:ed|ing|s)|head (?=left|right|up|down|forward|back)|"
     + _verb("track", "scoot", "nudge")
     + r"|edg(?:ed|es|ing)|inch(?:ed|es|ing)|"
     + rf"(?:{_verb('take')}) (?:a |one |two |three |several |a few |some )?"
     r"(?:small |big |short |long |single )?(?:steps?|paces?)",
     Sense(_STEP)),
    (r"mov\w*|motion|" + _verb("go", "come", "get", "bring", "draw"), Sense("weak")),
    (r"chang\w*|differ\w*|happen\w*", Sense("weak", "any")),
    # ---- directions
    (r"(?:to |toward |towards |on |at )?(?:the |its |their |his |her |your |my )?left(?:ward|"
     r"wards)?(?: hand)?(?: side| edge)?",
     Sense("way", "left")),
    (r"(?:to |toward |towards |on |at )?(?:the |its |their |his |her |your |my )?right(?:ward|"
     r"wards)?(?: hand)?(?: side| edge)?",
     Sense("way", "right")),
    (r"up(?:ward|wards)?|upper|above|higher|high|top|atop|overhead|skyward|"
     r"(?:toward|towards|to|at|face|faces|faced|facing) the (?:ceiling|sky)|taller|"
     r"over(?= (?:it|them|the|its)\b)",
     Sense("way", "up")),
    (r"down(?:ward|wards)?|below|beneath|under(?:neath)?|lower|low|bottom|"
     r"(?:toward|towards|to|at|face|faces|faced|facing) the (?:floor|ground)",
     Sense("way", "down")),
    (r"forwards?|forth|ahead|in front|front|frontward|onward|towards? the (?:scene|subject)|"
     r"(?:further|farther|deeper|closer|nearer) in|"
     r"into the scene|inward",
     Sense("way", "forward")),
    (r"backwards?|back|behind|rear(?:ward)?|reverse|away|outward", Sense("way", "backward")),
    (r"around|round", Sense("way", "around")),
)  # fmt: skip

LEXICON: tuple[tuple[re.Pattern[str], Sense], ...] = tuple(
    (re.compile(rf"\b(?:{pattern})\b"), meaning) for pattern, meaning in _ROWS
)
_DEGREES = re.compile(r"\b(\d+(?:\.\d+)?)\s*(?:°|degrees?\b|deg\b)")
# Words that carry no meaning of their own in a motion phrase (articles, the camera, hedges, ...).
_FILLER = frozenset(
    "a an the it its it s camera cameras lens photographer shooter viewer view views i we you he she they "
    "was were is are be been has had have did do does by to of and or then while but with as at in on "
    "from toward towards slightly somewhat a bit little bit about roughly approximately around nearly "
    "significantly noticeably mostly mainly primarily purely only just also both direction directions "
    "which way what how relative compared first second image photo picture frame shot snapshot one "
    "so that this that side edge s degrees degree deg slight small large big far much more bit "
    "diagonally diagonal straight directly scene subject objects object photographed place point spot "
    "location "
    "position height level reference off out original initial previous other ones earlier later "
    "now own few couple several while vantage standpoint than before along shooting capture "
    "m cm mm meter meters metre metres centimeter centimeters centimetre centimetres feet foot ft inches "
    "half quarter yard yards unit units physically exactly precisely actually really overall net "
    "sense centre center new over entire whole "
    "itself body there significant noticeable appreciable obvious visible clear "
    "real sharp sharply gentle gently quite lot amount tiny minor modest modestly moderate moderately "
    "considerable considerably substantial substantially aside "
    "executed performed through "
    "shots snapshots photos pictures images throughout our my operator cameraman camerawoman observer "
    "real completely perfectly totally entirely absolutely fully utterly essentially basically virtually "
    "practically almost marginally tad touch hair smidge smidgen notch trifle fraction".split()
)


@dataclass
class Token:
    start: int
    end: int
    sense: Sense
    words: str


def normalized(text: str) -> str:
    """Lower case; hyphens, slashes, apostrophes and punctuation as spaces; single spaces."""
    lowered = re.sub(r"[-_/'’]", " ", (text or "").lower())
    lowered = re.sub(r"[^a-z0-9°.\s]", " ", lowered)
    words = " ".join(lowered.replace(". ", " ").rstrip(".").split())
    # "image two" is "image 2": a photo's number in words, so the pair can be checked
    return _NUMBERED_VIEW.sub(lambda m: f"{m.group(1)} {_NUMBERS[m.group(2)]}", words)


_NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6}
_NUMBERED_VIEW = re.compile(
    r"\b(image|photo|picture|view|shot|frame|camera|snapshot|img) (one|two|three|four|five|six)\b"
)


def tokens(text: str) -> list[Token]:
    """The lexicon's rows found in a normalized text, earliest first, longest at a position, no overlaps."""
    found: list[Token] = []
    for pattern, sense in LEXICON:
        for match in pattern.finditer(text):
            found.append(Token(match.start(), match.end(), sense, match.group()))
    found.sort(key=lambda t: (t.start, -(t.end - t.start)))
    kept: list[Token] = []
    for token in found:
        if kept and token.start < kept[-1].end:
            continue
        kept.append(token)
    return kept


def unknown_words(text: str, found: list[Token]) -> list[str]:
    """The words of a normalized text that no token covers and that are no filler."""
    return [match.group() for match in _unknown_matches(text, found)]


def _unknown_matches(text: str, found: list[Token]) -> list[re.Match[str]]:
    covered = [False] * len(text)
    for token in found:
        covered[token.start : token.end] = [True] * (token.end - token.start)
    return [
        match
        for match in re.finditer(r"[a-z]+", text)
        if not covered[match.start()]
        and match.group() not in _FILLER
        and not _DEGREES.match(text, match.start())
    ]


@dataclass
class _Part:
    verb: Sense | None = None
    negated: bool = False
    ways: list[str] = field(default_factory=list)
    senses: list[str] = field(default_factory=list)
    words: list[str] = field(default_factory=list)
    axis: str | None = None  # set by an axis phrase ("about the lens axis")
    from_noun: bool = False  # opened by a noun of place ("its position ..."), not by a verb


_AXES = ("yaw", "pitch", "roll")
_IGNORED = ("filler", "hedge")  # words with no meaning of their own in a claim
_VERBS = ("step", "weak", "aim", "yaw", "pitch", "roll", "place", "still")
_STEPPING = ("step", "weak", "place")
_TURNING = ("aim", "yaw", "pitch", "roll")


def _joins(open_: _Part | None, verb: Sense, aiming: bool, negate: bool = False) -> bool:
    """Whether a verb belongs to the part before it: directions with no verb yet ("Left, moved"),
    a step verb after a stepping verb with no direction yet ("stepped closer", "stood farther
    back"), a verb of aiming after a turn with no side yet ("rotated to face left"), or any verb
    after an orientation noun ("its aim rose"). A negated verb opens its own part ("Up, without
    turning")."""
    if open_ is None or open_.negated or negate:
        return False
    if open_.verb is None or aiming:
        return True
    if open_.verb.kind in _TURNING and not open_.ways and not open_.senses:
        return verb.kind == "aim" and not verb.value
    if open_.verb.kind not in _STEPPING or open_.ways or verb.kind not in ("step", "weak"):
        return False
    # "walked a few steps left", "got nearer": one step said with two verbs
    return bool(verb.value) or open_.verb.kind in ("step", "weak")


def _add_verb(parts: list[_Part], token: Token, negate: bool, aiming: bool) -> None:
    open_ = parts[-1] if parts else None
    joins = _joins(open_, token.sense, aiming, negate)
    part = open_ if joins and open_ is not None else _Part()
    keep_open_kind = joins and part.verb is not None and part.verb.kind in ("place", "step", *_TURNING)
    if not keep_open_kind:
        part.verb = Sense("aim") if aiming else token.sense
    part.negated = part.negated or negate
    if token.sense.value and token.sense.value != "any":
        part.ways.append(token.sense.value)
    part.words.append(token.words)
    if part is not open_:
        parts.append(part)


def _parts(found: list[Token]) -> list[_Part]:
    """Tokens grouped by verb: each verb opens a part; directions before any verb open a bare one."""
    parts: list[_Part] = []
    negate = aiming = False
    for token in found:
        kind = token.sense.kind
        if kind == "not":
            negate = True
        elif kind == "aimnoun" and _aims_at(parts, negate):
            # the orientation as the object ("turned its gaze upward", "lowered its aim"): the
            # verb before it turned the camera
            parts[-1].verb = Sense("aim")
            parts[-1].words.append(token.words)
        elif kind == "aimnoun":  # "its aim", "the heading": the verb that follows turns the camera
            aiming = True
            parts.append(_Part(verb=Sense("aim"), words=[token.words]))
        elif kind == "placenoun":
            # "its position shifted left", "height: up", "a higher position": the camera's place
            # makes the directions a step; after a verb it adds nothing ("moved to a new position")
            if not parts or parts[-1].verb is None:
                opened = not parts
                _add_verb(parts, Token(token.start, token.end, Sense("weak"), token.words), negate, aiming)
                parts[-1].from_noun = opened
                negate = False
        elif kind in _VERBS:
            _add_verb(parts, token, negate, aiming)
            negate = aiming = False
        elif kind == "axis":
            if not parts:
                parts.append(_Part())
            parts[-1].axis = token.sense.value
            parts[-1].words.append(token.words)
        else:
            if not parts:
                parts.append(_Part(negated=negate))
            elif negate:  # a negated direction ("not left") says what did not happen: no claim of ours
                parts[-1].negated = True
            negate = False
            target = parts[-1]
            (target.senses if kind == "sense" else target.ways).append(str(token.sense.value))
            target.words.append(token.words)
    return parts


def _aims_at(parts: list[_Part], negate: bool) -> bool:
    """Whether an orientation noun is the object of the verb just before it: a turning verb with
    no direction yet, or a raising or lowering one ("lowered its aim")."""
    if not parts or negate or parts[-1].verb is None or parts[-1].negated:
        return False
    part = parts[-1]
    if part.verb.kind in _TURNING:
        return not part.ways and not part.senses
    return part.verb.kind == "step" and part.ways in (["up"], ["down"])


def _kind_nouns_folded(parts: list[_Part]) -> list[_Part]:
    """A verb alone right after a part of its own family names that part's kind ("moved left
    (translation)", "turned right, a yaw"): it joins the part, and a verb of one axis replaces a
    general turn so the axis is checked against the direction."""
    folded: list[_Part] = []
    for part in parts:
        previous = folded[-1] if folded else None
        alone = part.verb is not None and not (part.ways or part.senses or part.axis or part.negated)
        if alone and previous is not None and previous.verb is not None and not previous.negated:
            kind, before = part.verb.kind, previous.verb.kind
            if kind in ("step", "weak") and not part.verb.value and before in ("step", "weak"):
                previous.words += part.words
                continue
            if kind in _TURNING and (kind == before or before == "aim"):
                previous.verb = part.verb
                previous.words += part.words
                continue
        folded.append(part)
    return folded


def _conflict(ways: list[str]) -> str | None:
    distinct = set(ways)
    for one, other in (("left", "right"), ("up", "down"), ("forward", "backward")):
        if one in distinct and other in distinct:
            return f"it names both {one} and {other}"
    return None


def _rotation(part: _Part, degrees: float | None, source: str) -> Claim:
    axis = part.axis or {"yaw": "yaw", "pitch": "pitch", "roll": "roll"}.get(
        part.verb.kind if part.verb else "", None
    )
    ways = list(dict.fromkeys(part.ways))
    senses = list(dict.fromkeys(part.senses))
    if (
        part.negated
        and axis is None
        and not part.ways
        and not part.senses
        and any(w.startswith(("rotat", "rotation")) for w in part.words)
    ):
        # "did not rotate", "no rotation": about no axis at all
        return Compound(
            parts=tuple(Rotation(axis=a, sense="none", source=source) for a in _AXES), source=source
        )
    if part.negated and (part.ways or part.senses):
        # "did not turn left" says which turn did not happen, not which did
        return Unread(source=source, why="a negated direction states no motion")
    if part.negated:
        return Rotation(axis=axis or "yaw", sense="none", source=source)
    if len(senses) > 1:
        return Unread(source=source, why="it names both clockwise and counterclockwise")
    if (
        senses
        and axis == "yaw_from_above"
        and not ways
        and (part.verb is None or part.verb.kind in ("aim", "yaw"))
    ):
        # seen from above, a clockwise turn swings the view to the right
        side = "right" if senses[0] == "clockwise" else "left"
        return Rotation(axis="yaw", sense=side, degrees=degrees, source=source)
    if axis == "yaw_from_above":
        return Unread(source=source, why="a sense seen from above fits only a turn")
    if senses and axis == "pitch" and part.verb is not None and part.verb.kind == "pitch" and not ways:
        axis = "roll"  # "tilted clockwise": a tilt with a clock sense is a dutch tilt, about the lens
    if senses:
        if ways or axis not in (None, "roll"):
            return Unread(source=source, why="it names a roll's sense with another direction")
        return Rotation(axis="roll", sense=senses[0], degrees=degrees, source=source)
    if len(ways) != 1:
        why = "a turn with no side" if not ways else "a turn with several sides"
        return Unread(source=source, why=why)
    way = ways[0]
    inferred = {
        "left": "yaw",
        "right": "yaw",
        "around": "yaw",
        "backward": "yaw",
        "up": "pitch",
        "down": "pitch",
    }
    if way == "forward" or (axis is not None and axis != inferred.get(way)):
        return Unread(source=source, why=f"a {axis or 'turn'} toward {way} is no rotation the lexicon knows")
    sense = "around" if way in ("around", "backward") else way
    return Rotation(axis=inferred[way], sense=sense, degrees=degrees, source=source)  # type: ignore[arg-type]


def _part_claim(part: _Part, degrees: float | None, source: str) -> Claim:
    kind = part.verb.kind if part.verb else None
    if kind == "still":
        return Still(source=source)
    if kind in ("aim", "yaw", "pitch", "roll") or (kind is None and (part.senses or part.axis)):
        return _rotation(part, degrees, source)
    if part.negated:
        if kind in ("step", "weak") and not part.ways:
            return Still(source=source)
        return Unread(source=source, why="a negated direction states no motion")
    if kind is None and part.ways == ["around"]:
        return Rotation(axis="yaw", sense="around", source=source)  # "Around": only a turn goes around
    ways = [w for w in dict.fromkeys(part.ways) if w != "around"]
    conflict = _conflict(ways)
    if conflict:
        return Unread(source=source, why=conflict, two_claims=True)
    if not ways:
        return Unread(source=source, why="a motion with no direction")
    typed: tuple[Way, ...] = tuple(ways)  # type: ignore[assignment]
    if kind in ("step", "weak"):
        return Translation(ways=typed, source=source)
    if kind == "place":
        return Position(ways=typed, source=source)
    return Bare(ways=typed, source=source)


# "closer to the lamp", "farther away from the red sofa": the object's name is not the lexicon's.
_TARGET = re.compile(
    r"^(?:(?:it|the camera|camera)\s+)?(?:(?:came|got|moved|went|is|was|ended up)\s+)?"
    r"(?P<change>closer|nearer|farther|further)\s+(?:away\s+)?(?:to|from)\s+"
    r"(?P<object>(?!the (?:scene|subject|left|right|top|bottom|front|back|rear|objects?|things|view|room|"
    r"contents?|surroundings|background|foreground|camera|first|second|other|previous|original)\b)"
    r"(?:the|a|an)\s+[a-z ]+)$"
)


# What moves when these are the subject is the picture's content: it shifts the opposite way to the
# camera ("the scene slid left" when the camera turned or stepped right). That inversion is not
# read: the option is left unread rather than risk a claim of the wrong sign.
_CONTENT = re.compile(
    r"\b(?:scene|scenery|objects?|contents?|things|everything|world|background|foreground|surroundings|"
    r"room|furniture|subject|images?|pictures?|photos?|frames?)\b"
)
_CAMERA_SUBJECT = re.compile(
    r"\b(?:camera|it|photographer|shooter|viewer|lens|\d+|first|second|third|last|later|latter|new|final|"
    r"next|cameraman|camerawoman|operator|observer|our|my|i|we)\b"
)
# "moved left in the frame" (content), not "moved left in image 1's frame" (whose directions)
_IN_THE_PICTURE = re.compile(
    r"\bin (?:the )?(?:frame|image|picture|photo|shot)\b(?! \d| s\b| (?:one|two|three|four|five|plane)\b)"
)
# What the camera sees as the subject of a step ("the view shifted left"): a pan moves the view as
# much as a step does, so which motion is meant is not said.
_VIEW_SUBJECT = re.compile(r"\b(?:view|shot|framing|perspective|composition|field of view|picture frame)\b")
# ... or as the object of a step ("raised its view", "shifted the framing left")
_VIEW_OBJECT = re.compile(
    r" (?:its|the|camera s|the camera s) (?:view|shot|framing|perspective|composition)\b"
)
# The first (reference) camera as the subject ("the first camera is to the left of the second"):
# its place relative to the second is the second's place reversed; not read.
_EARLIER = r"(?:first|earlier|reference|original|initial|previous|former|starting|older)"
_LATER = r"(?:second|later|latter|new|newer|next|final|last|other)"
_CAMERA_NOUN = r"(?:camera|image|photo|picture|view|shot|snapshot|frame|one|position|viewpoint)"
_REFERENCE_SUBJECT = re.compile(
    rf"^(?:the )?(?:(?:position|location|place|centre|center) of (?:the )?)?{_EARLIER}"
    rf"(?: {_CAMERA_NOUN}\b| (?=is|was|lies|lay|sits|sat|stands|stood|appears|had)\b)"
)
# ... or the second camera as the reference ("to the left of the second camera"): the claim is the
# first camera's place, the reverse of what is asked
_LATER_REFERENCE = re.compile(
    rf"\b(?:of|than|from|to|relative to|compared (?:to|with)|with respect to|above|below|behind) "
    rf"(?:the )?{_LATER} {_CAMERA_NOUN}\b"
)
_NO_CLAIM = {
    "source": "a direction it came from is the opposite of the way it went",
    "zoom": "a zoom changes the focal length, not the camera's place",
    "survey": "looking around is a scan, not a turn to one side",
    "camera_angle": "a high or low camera angle says both where it stands and where it looks",
    "return": "a return to an earlier place states no direction",
}


# A clause whose subject is the picture's content, right before its verb ("... so the scene moved
# right", "... and objects shifted left").
_CONTENT_CLAUSE = re.compile(
    r"\b(?:the |its |all |some |everything |the whole )?(?P<noun>scene|scenery|objects?|contents?|things|"
    r"everything|world|background|foreground|surroundings|room|furniture|subject|image|picture|photo|"
    r"frame|horizon)(?: in (?:the )?(?:frame|view|image|picture|photo))?(?: (?:appears?|appeared|seems?|"
    r"seemed) to(?: have)?(?: been)?| (?:probably|apparently|seemingly|evidently|clearly|obviously))* $"
)


def _later_content_subject(words: str, found: list[Token]) -> str | None:
    """The content noun that is the subject of a verb after the first one, if any."""
    previous_end = None
    for token in found:
        if token.sense.kind in _VERBS and token.sense.kind != "place" and previous_end is not None:
            clause = _CONTENT_CLAUSE.search(words[previous_end : token.start])
            if clause:
                return clause.group("noun")
        if token.sense.kind not in _IGNORED:  # "the scene then appears to have shifted": one clause
            previous_end = token.end
    return None


# The scene's own things (not a photo's name, as in "image 2's camera"): named before the camera
# ("the subject in image 2") or owned by it ("the camera's subject"), they are the clause's subject.
_SCENE_THING = re.compile(
    r"\b(?:scene|scenery|objects?|contents?|things|everything|world|background|foreground|surroundings|"
    r"room|furniture|subject)\b"
)


def _content_is_the_subject(subject: str) -> bool:
    camera = _CAMERA_SUBJECT.search(subject)
    if camera is None:
        return True
    thing = _SCENE_THING.search(subject)
    if thing is None:
        return False
    owned = re.search(r"\bs (?:\w+ )?" + re.escape(thing.group()) + r"\b", subject)
    return thing.start() < camera.start() or owned is not None


def _content_moved(subject: str, verb: Token | None) -> str | None:
    """Why a subject that is the picture's content ("the scene", "objects") states no camera claim."""
    content = _CONTENT.search(subject)
    # "the photos were taken from the same spot" is a stillness, "the scene stayed still" not ours
    moving = verb is not None and verb.sense.kind not in ("place", "still")
    # "the subject sat to the left" is the subject's place; "image 2 sits above" is the camera's
    thing_placed = verb is not None and _SCENE_THING.search(subject) is not None
    if content and (moving or thing_placed) and _content_is_the_subject(subject):
        return (
            f"it says the {content.group()} moved: content shifts in the frame opposite to the camera, "
            "which is not read"
        )
    return None


def _no_claim(words: str, found: list[Token]) -> str | None:
    """Why words that look like motion state no claim about the camera, else None."""
    for token in found:
        if token.sense.kind in _NO_CLAIM:
            return _NO_CLAIM[token.sense.kind]
    verb = next((t for t in found if t.sense.kind in _VERBS), None)
    subject = words[: verb.start] if verb is not None else ""
    # after a hedge that opens a clause ("it looks like the scene moved"), the clause has its own subject
    hedges = [t.end for t in found if t.sense.kind == "hedge" and verb is not None and t.end <= verb.start]
    for said in (subject, words[hedges[-1] : verb.start] if hedges and verb is not None else ""):
        if refusal := _content_moved(said, verb):
            return refusal
    stepping = verb is not None and verb.sense.kind in ("step", "weak")
    if stepping and _VIEW_SUBJECT.search(subject):
        return "it says the view moved, which a step and a turn both do"
    if stepping and verb is not None and _VIEW_OBJECT.match(words, verb.end):
        return "it says the view was moved, which a step and a turn both do"
    if later := _later_content_subject(words, found):
        return (
            f"a clause says the {later} moved: content shifts in the frame opposite to the camera, "
            "which is not read"
        )
    if _REFERENCE_SUBJECT.match(words) or _LATER_REFERENCE.search(words):
        return "it says where the first camera is, relative to the second (the reverse of what is asked)"
    if _IN_THE_PICTURE.search(words[verb.end :] if verb is not None else words):
        return "it describes motion within the picture, not the camera's"
    return None


def read_phrase(text: str) -> Claim:
    """The claim an option states (see the module docstring)."""
    words = normalized(text)
    if target := _TARGET.match(words):
        change = "closer" if target.group("change") in ("closer", "nearer") else "farther"
        return Target(change=change, object=target.group("object"), source=text)
    found = tokens(words)
    unknown = unknown_words(words, found)
    if unknown:
        return Unread(source=text, why=f"{', '.join(repr(w) for w in unknown)} is not in the motion lexicon")
    if not found:
        return Unread(source=text)
    if refusal := _no_claim(words, found):
        return Unread(source=text, why=refusal)
    found = [token for token in found if token.sense.kind not in _IGNORED]
    if not found:
        return Unread(source=text, why="it states no direction, kind of motion or stillness")
    if any(token.sense.kind == "or" for token in found):
        return Unread(source=text, why="it offers two claims joined by 'or'", two_claims=True)
    stated = _DEGREES.search(words)
    degrees = float(stated.group(1)) if stated else None
    parts = _kind_nouns_folded(_parts(found))
    # "its position and direction were unchanged": a noun of place that no direction follows states
    # nothing of its own
    parts = [
        p for p in parts if not (p.from_noun and not p.ways and p.verb is not None and p.verb.kind == "weak")
    ]
    claims = [_part_claim(part, degrees, " ".join(part.words)) for part in parts]
    # "moved right without rotating": "no rotation" is itself a compound (no turn about any axis)
    claims = [p for c in claims for p in (c.parts if isinstance(c, Compound) else (c,))]
    if not claims:  # a negation, "or", with nothing it applies to
        return Unread(source=text, why="it states no direction, kind of motion or stillness")
    unread = next((c for c in claims if isinstance(c, Unread)), None)
    if unread is not None:
        return unread.model_copy(update={"source": text})
    rotations = [c for c in claims if isinstance(c, Rotation)]
    if rotations and all(r.sense == "none" for r in rotations) and any(isinstance(c, Still) for c in claims):
        return Still(source=text)  # "no displacement and no rotation": nothing moved
    if rotations and any(isinstance(c, Still) for c in claims):
        # "stayed in place and turned left": in place is no step, and the turn is the claim
        claims = [c for c in claims if not isinstance(c, Still)]
    claims = _merged(claims, text)
    if isinstance(claims, Unread):
        return claims
    if len(claims) == 1:
        return claims[0].model_copy(update={"source": text})
    if any(isinstance(c, Bare) for c in claims):
        return Unread(source=text, why="directions that belong to no verb next to a verb")
    return Compound(parts=tuple(claims), source=text)  # type: ignore[arg-type]


_FAMILY = {
    "step": "translation",
    "place": "position",
    "aim": "rotation",
    "yaw": "rotation",
    "pitch": "rotation",
    "roll": "rotation",
    "still": "still",
}


def kinds_named(text: str) -> frozenset[str]:
    """The kinds of claim an option's verbs name, also when the option itself is not read (a word
    outside the lexicon, a direction that does not fit its verb): "It rolled toward the clock's
    hands" names a rotation though no sense is read. For the quantity a question asks only, never
    for a claim. Empty when nothing names a kind that way: an everyday verb alone ("it moved"), a
    negated one, a scene or a view as what moved, alternatives joined by "or", or a word not read
    before the first verb (it may be the subject: "the tripod moved left")."""
    words = normalized(text)
    found = tokens(words)
    verbs = [token for token in found if token.sense.kind in _VERBS]
    if not verbs or _TARGET.match(words) or _no_claim(words, found):
        return frozenset()
    if any(m.start() < verbs[0].start for m in _unknown_matches(words, found)):
        return frozenset()
    meaningful = [token for token in found if token.sense.kind not in _IGNORED]
    if any(token.sense.kind == "or" for token in meaningful):
        return frozenset()
    kinds: set[str] = set()
    for part in _kind_nouns_folded(_parts(meaningful)):
        if part.negated or part.verb is None:
            continue
        claim = _part_claim(part, None, "")
        if isinstance(claim, Translation | Position | Rotation | Still | Compound):
            kinds |= claim_kinds(claim)
        elif part.verb.kind in _FAMILY:
            kinds.add(_FAMILY[part.verb.kind])
    return frozenset(kinds)


def _merged(claims: list[Claim], text: str) -> list[Claim] | Unread:
    """Parts of one kind said twice are one claim: "stepped backward, away from the scene" is one
    step back, "stepped back and moved left" one diagonal step; two senses about one axis ("turned
    left, then right") are two claims."""
    merged: list[Claim] = []
    for claim in claims:
        same = next((m for m in merged if type(m) is type(claim)), None)
        if isinstance(claim, Translation | Position) and isinstance(same, Translation | Position):
            ways = tuple(dict.fromkeys((*same.ways, *claim.ways)))
            if conflict := _conflict(list(ways)):
                return Unread(source=text, why=conflict, two_claims=True)
            merged[merged.index(same)] = same.model_copy(update={"ways": ways})
            continue
        if isinstance(claim, Rotation):
            twin = next((m for m in merged if isinstance(m, Rotation) and m.axis == claim.axis), None)
            if twin is not None and twin.sense != claim.sense:
                return Unread(source=text, why=f"it names two {claim.axis} senses", two_claims=True)
            if twin is not None:
                continue
        if isinstance(claim, Still) and any(isinstance(m, Still) for m in merged):
            continue  # "stayed fixed in place": one stillness said twice
        if claim not in merged:
            merged.append(claim)
    return merged


_VIEW_NOUN = r"(?:image|photo|picture|view|shot|frame|camera|snapshot)(?: number| no| #)?"
_SUBJECT_VIEW = re.compile(rf"^(?:the )?{_VIEW_NOUN} (\d+)\b|^(?:the )?(\d+)(?:st|nd|rd|th)? {_VIEW_NOUN}\b")
_REFERENCE_VIEW = re.compile(
    rf"\b(?:of|than|from|to|relative to|compared (?:to|with)|with respect to|above|below|under|beneath|"
    rf"behind|over) (?:the )?"
    rf"(?:{_VIEW_NOUN} (\d+)|(\d+)(?:st|nd|rd|th)? {_VIEW_NOUN})(?: s)?\b"
)


def views_named(text: str) -> tuple[int | None, int | None]:
    """(the view an option is about, the view it is relative to), each by its number when the option
    names one ("Image 2 was taken to the left of image 1": (2, 1)); the reading checks them
    against the pair, since the lexicon does not know it."""
    words = normalized(text)
    subject = _SUBJECT_VIEW.search(words)
    reference = _REFERENCE_VIEW.search(words, subject.end() if subject else 0)
    first = next((int(g) for g in subject.groups() if g), None) if subject else None
    second = next((int(g) for g in reference.groups() if g), None) if reference else None
    return first, second


def stem_senses(text: str) -> list[Sense]:
    """Every meaning the lexicon finds in a question's stem, in order."""
    return [token.sense for token in tokens(normalized(text))]


__all__ = [
    "LEXICON",
    "Sense",
    "Token",
    "kinds_named",
    "normalized",
    "read_phrase",
    "stem_senses",
    "tokens",
    "unknown_words",
    "views_named",
]
