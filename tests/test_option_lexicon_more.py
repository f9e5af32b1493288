"""A second batch of option wordings, written for this file, in kinds of language the first table
(tests/test_option_lexicon.py) does not cover: nouns of motion ("a leftward shift", "a slight turn to
the right"), passive voice ("the camera was moved left"), camera-operator terms (truck, dolly,
pedestal, boom), colloquial verbs, hedges and magnitudes with units, the second camera's place said
many ways, stillness said many ways, and near-misses that must stay unread. Short forms as in that
file (``T left``, ``P up``, ``R yaw left``, ``S``, ``B left``, ``C ...``, ``U``, ``U2``).
"""

from __future__ import annotations

import pytest

from shared.questions.claims import Unread
from shared.questions.lexicon import read_phrase
from tests.test_option_lexicon import short

NOUNS = [
    ("A leftward shift", "T left"),
    ("A shift to the right", "T right"),
    ("A rise", "T up"),
    ("A small rise in height", "T up"),
    ("A drop in height", "T down"),
    ("A slight turn to the right", "R yaw right"),
    ("A sharp turn to the left", "R yaw left"),
    ("A clockwise twist", "R roll clockwise"),
    ("A counterclockwise roll of about 10 degrees", "R roll counterclockwise"),
    ("A step back", "T backward"),
    ("A step to the left", "T left"),
    ("A couple of steps forward", "T forward"),
    ("An upward tilt", "R pitch up"),
    ("A downward tilt of the camera", "R pitch down"),
    ("A pan to the left", "R yaw left"),
    ("A rightward pan", "R yaw right"),
    ("A move to the right", "T right"),
    ("A movement toward the scene", "T forward"),
    ("An upward movement", "T up"),
    ("A lateral shift to the left", "T left"),
    ("A descent", "T down"),
    ("An ascent", "T up"),
    ("A leftward rotation", "R yaw left"),
    ("A rotation to the right", "R yaw right"),
    ("A turn of roughly 30 degrees to the left", "R yaw left"),
    ("A backward step", "T backward"),
    ("A forward dolly", "T forward"),
    ("A truck to the left", "T left"),
    ("A slide to the right", "T right"),
    ("A retreat from the scene", "T backward"),
]

ADVERBS = [
    ("Leftwards", "B left"),
    ("Rightward", "B right"),
    ("Skyward", "B up"),
    ("Went skyward", "T up"),
    ("Moved leftwards", "T left"),
    ("Rightwards, a little", "B right"),
    ("Downwards", "B down"),
    ("Turned rightwards", "R yaw right"),
    ("Tilted skyward", "R pitch up"),
    ("Backwards", "B backward"),
]

PASSIVE = [
    ("The camera was moved left", "T left"),
    ("The camera was moved to the right", "T right"),
    ("It was raised", "T up"),
    ("The camera was raised higher", "T up"),
    ("It was lowered", "T down"),
    ("The camera was rotated clockwise", "R roll clockwise"),
    ("The camera was turned to the left", "R yaw left"),
    ("It was panned right", "R yaw right"),
    ("The camera was tilted upward", "R pitch up"),
    ("It was shifted leftward", "T left"),
    ("It was pushed forward", "T forward"),
    ("The camera was pulled back", "T backward"),
    ("It was carried to the right", "T right"),
    ("The camera was brought closer", "T forward"),
    ("It was slid to the left", "T left"),
    ("The camera was swung to the right", "R yaw right"),
    ("The camera was rolled counterclockwise", "R roll counterclockwise"),
    ("The camera was repositioned to the left", "T left"),
    ("The camera has been moved up", "T up"),
    ("The camera got moved back", "T backward"),
]

OPERATOR = [
    ("Truck left", "T left"),
    ("Trucking right", "T right"),
    ("Dolly in", "T forward"),
    ("Dolly out", "T backward"),
    ("Dollied forward", "T forward"),
    ("Dollied backward", "T backward"),
    ("Pedestal up", "T up"),
    ("Pedestal down", "T down"),
    ("Boom up", "T up"),
    ("Boom down", "T down"),
    ("Pan left", "R yaw left"),
    ("Pan right", "R yaw right"),
    ("Tilt up", "R pitch up"),
    ("Tilt down", "R pitch down"),
    ("Roll clockwise", "R roll clockwise"),
    ("A dutch angle, clockwise", "R roll clockwise"),
    ("Crab right", "T right"),
    ("Track left", "T left"),
    ("Craned down", "R pitch down"),
    ("Push in", "T forward"),
    ("Pull out", "T backward"),
    ("Pedestalled up", "T up"),
    ("Booming down", "T down"),
]

COLLOQUIAL = [
    ("Scooted over to the left", "T left"),
    ("Shuffled back", "T backward"),
    ("Bobbed up", "T up"),
    ("Hopped to the right", "T right"),
    ("Stepped aside to the left", "T left"),
    ("Shimmied left", "T left"),
    ("Ducked down", "T down"),
    ("Hunkered down", "T down"),
    ("Crept forward", "T forward"),
    ("Crept closer", "T forward"),
    ("Inched to the right", "T right"),
    ("Nudged left", "T left"),
    ("Edged back", "T backward"),
    ("Headed left", "T left"),
    ("Wandered to the right", "T right"),
    ("Moseyed forward", "T forward"),
    ("Got lower", "T down"),
    ("Got higher", "T up"),
    ("Whipped around", "R yaw around"),
    ("Spun around", "R yaw around"),
    ("Swung round to the left", "R yaw left"),
    ("Peeked to the right", "R yaw right"),
    ("Glanced upward", "R pitch up"),
    ("Looked skyward", "R pitch up"),
]

HEDGES = [
    ("Mostly to the left", "B left"),
    ("A bit higher than before", "B up"),
    ("Somewhat further to the right", "B right"),
    ("Moved about 2 meters to the left", "T left"),
    ("Moved roughly 50 cm forward", "T forward"),
    ("Rose by around 30 centimetres", "T up"),
    ("Shifted 1.5 m right", "T right"),
    ("Turned about 45 degrees left", "R yaw left"),
    ("Turned 90° to the right", "R yaw right"),
    ("Tilted up by 15 degrees", "R pitch up"),
    ("Moved a few feet back", "T backward"),
    ("Moved a little to the left", "T left"),
    ("Moved just slightly right", "T right"),
    ("Moved noticeably higher", "T up"),
    ("Turned sharply to the left", "R yaw left"),
    ("Turned gently right", "R yaw right"),
    ("Quite a bit to the left", "B left"),
    ("Moved left by a small amount", "T left"),
    ("Moved primarily to the right", "T right"),
    ("Only slightly lower", "B down"),
]

PLACES = [
    ("It stood to the left of the first one", "P left"),
    ("The second camera sits higher up", "P up"),
    ("Farther from the subject", "T backward"),
    ("It is located further to the right", "P right"),
    ("It was positioned lower than the first", "P down"),
    ("The second camera is placed behind the first", "P backward"),
    ("The second photo was taken closer to the scene", "P forward"),
    ("It is to the right of where the first photo was taken", "B right"),
    ("The second viewpoint is above the first", "B up"),
    ("The new camera position is further left", "T left"),
    ("The second camera lies to the left", "P left"),
    ("Image 2 was shot from the right of image 1", "U"),
    ("The second view was captured from a higher spot", "P up"),
    ("The later camera is situated lower", "P down"),
    ("The second camera stands in front of the first", "P forward"),
    ("It sits to the right", "P right"),
    ("It is higher than the first camera", "B up"),
    ("It is further back than the first camera", "T backward"),
    ("On the left of the first camera", "B left"),
    ("Positioned toward the right", "P right"),
]

STILL = [
    ("It did not move at all", "S"),
    ("No motion at all", "S"),
    ("The camera remained in place", "S"),
    ("The camera stayed exactly where it was", "S"),
    ("It held still", "S"),
    ("It kept still", "S"),
    ("Both shots were taken from the same spot", "S"),
    ("Taken from the same position", "S"),
    ("The camera did not change position", "S"),
    ("Same place, same direction", "S"),
    ("It remained fixed", "S"),
    ("No change in position", "S"),
    ("The camera was not moved", "S"),
    ("It was stationary", "S"),
    ("No movement of the camera", "S"),
    ("The camera was kept still", "S"),
    ("It didn't budge", "S"),
    ("Neither moved nor turned", "S"),
    ("No translation and no rotation", "S"),
    ("It stayed in the same location", "S"),
]

NEAR_MISSES = [
    # the subject or scene moving
    ("The subject walked to the left", "U"),
    ("The people moved closer", "U"),
    ("The scene rotated clockwise", "U"),
    ("The background moved to the right", "U"),
    ("The objects appear to shift left", "U"),
    ("The car drove to the left", "U"),
    # zoom, focus, exposure: not the camera's place or aim
    ("Zoomed in on the subject", "U"),
    ("The lens zoomed out", "U"),
    ("A zoom to the left", "U"),
    ("Refocused on the background", "U"),
    ("The focus shifted left", "U"),
    ("The exposure went up", "U"),
    ("The brightness rose", "U"),
    ("The image got darker", "U"),
    # alternatives
    ("Left or right", "U2"),
    ("Either forward or backward", "U2"),
    ("Tilted up or down", "U2"),
    ("Moved left or turned left", "U2"),
    # negated directions
    ("Not upward", "U"),
    ("Never moved left", "U"),
    ("It did not rotate clockwise", "U"),
    ("Did not pan right", "U"),
    ("It didn't go up", "U"),
    # contradictory compounds
    ("Moved left and right", "U2"),
    ("Rolled clockwise and counterclockwise", "U"),
    ("Went up and then down", "U2"),
    ("Forward and backward", "U2"),
    # too little said or an idiom
    ("Turned over", "U"),
    ("Moved on", "U"),
    ("Rolled over", "U"),
    ("Stepped up its game", "U"),
    ("Looked around", "U"),
    ("It panned out", "U"),
    ("Unclear", "U"),
    ("Hard to tell", "U"),
    ("Cannot tell from the images", "U"),
]

LABELS_AND_SUBJECTS = [
    ("Translation: left", "T left"),
    ("Yaw: right", "R yaw right"),
    ("Roll: counterclockwise", "R roll counterclockwise"),
    ("Moved left (translation)", "T left"),
    ("Turned right (yaw)", "R yaw right"),
    ("Tilted down, a pitch", "R pitch down"),
    ("Lateral movement to the right", "T right"),
    ("Moved a short distance left", "T left"),
    ("Moved a long way to the right", "T right"),
    ("Strolled forward", "T forward"),
    ("Paced backward", "T backward"),
    ("Marched ahead", "T forward"),
    ("It remained stationary throughout", "S"),
    ("The operator panned left", "R yaw left"),
    ("The cameraman moved right", "T right"),
    ("The camera operator stepped back", "T backward"),
    ("The person holding the camera walked forward", "T forward"),
    ("My position moved right", "T right"),
    ("Second image taken further right", "P right"),
    ("Photo 2 captured from higher up", "P up"),
    ("Moved right, away from the first position", "T right"),
    ("Pulled to the left", "T left"),
]

# a kind noun after a part must fit it; a verb with no side stays unread
KIND_NOUN_MISSES = [
    ("Turned up (yaw)", "U"),
    ("Turned left (pitch)", "U"),
    ("Moved left and turned", "U"),
    ("Tilted up and panned", "U"),
    ("Rolled left (roll)", "U"),
    ("The camera pulled up", "U"),
    ("Pushed up", "U"),
    ("The subject walked a long way left", "U"),
    ("The observer's subject moved left", "U"),
    ("The camera's subject moved left", "U"),
    ("The subject in image 2 moved left", "U"),
    ("The objects seen by the camera shifted right", "U"),
]

# the second camera's place said with verbs of setting and standing, and heights as adjectives
SETTINGS = [
    ("Set off to the left", "P left"),
    ("Perched higher", "P up"),
    ("It was mounted higher", "P up"),
    ("It was held lower", "P down"),
    ("The later camera is set back", "P backward"),
    ("Standing to the left", "P left"),
    ("Sitting above", "P up"),
    ("It was set up further left", "P left"),
    ("Up high", "B up"),
    ("Down low", "B down"),
    ("Out to the right", "B right"),
    ("Way off to the left", "B left"),
    ("Nearer the scene than it", "T forward"),
    ("The camera sat still", "S"),
    ("It held still", "S"),
    # a high or low camera angle: where it stands and where it looks at once
    ("Taken from a high angle", "U"),
    ("A low-angle shot", "U"),
    ("A bird's-eye angle", "U"),
]

# rolls, stillness and turns in everyday sentences
EVERYDAY = [
    ("It tilted clockwise", "R roll clockwise"),
    ("It leaned counterclockwise", "R roll counterclockwise"),
    ("It revolved clockwise", "R roll clockwise"),
    ("Twirled anticlockwise", "R roll counterclockwise"),
    ("Took a turn to the left", "R yaw left"),
    ("It made a right turn", "R yaw right"),
    ("It took a left turn", "R yaw left"),
    ("Made a move to the right", "T right"),
    ("It stayed at rest", "S"),
    ("At rest", "S"),
    ("It rested in place", "S"),
    ("It remained where it stood", "S"),
    ("It stood its ground", "S"),
    ("Stayed as it was", "S"),
    ("It sat still", "S"),
    ("No movement or rotation", "S"),
    ("No rotation and no translation", "S"),
    ("It stayed fixed in place", "S"),
    ("It did not change its pose", "S"),
    ("Unmoved and unrotated", "S"),
    # still unread: the sense of a swivel or spin to a side, a lean to a side, a dip
    ("Tilted up clockwise", "U"),
    ("It leaned left", "U"),
    ("Swiveled clockwise", "U"),
    ("It spun left", "U"),
    ("It dipped down", "U"),
    ("Took a photo from the left", "U"),
]

# toward and away from the scene, and heights, in idioms
IDIOMS = [
    ("It crept up on the scene", "T forward"),
    ("It walked up to the subject", "T forward"),
    ("It fell back", "T backward"),
    ("It closed the distance", "T forward"),
    ("It reduced its distance to the scene", "T forward"),
    ("It increased its distance from the subject", "T backward"),
    ("It gained altitude", "T up"),
    ("It lost elevation", "T down"),
    ("It eased back", "T backward"),
    ("It eased left", "T left"),
    ("It surged forward", "T forward"),
    ("It went up toward the ceiling", "T up"),
]

# where it ended, said with verbs of arriving
ENDINGS = [
    ("Further out to the left", "B left"),
    ("It wound up on the left", "B left"),
    ("It finished to the right", "B right"),
    ("It landed further right", "B right"),
    ("It came to rest further left", "B left"),
    ("It settled lower", "B down"),
    ("It ended higher", "B up"),
    ("Dead ahead", "B forward"),
    ("Well to the left", "B left"),
    ("Atop it", "B up"),
    ("It settled", "U"),
]

# the orientation as a noun subject
ORIENTATION_NOUNS = [
    ("Its direction shifted left", "R yaw left"),
    ("Its bearing swung right", "R yaw right"),
    ("Its bearing shifted left", "R yaw left"),
    ("Its optical axis tilted down", "R pitch down"),
    ("The camera's gaze drifted left", "R yaw left"),
    ("Rolled through 15 degrees clockwise", "R roll clockwise"),
    ("It rotated about its forward axis clockwise", "R roll clockwise"),
    ("Its yaw went left", "U"),
    ("A roll to the left", "U"),
    ("The horizon rotated counterclockwise", "U"),
    # the scene's place, and the scene made to move
    ("The subject sat to the left", "U"),
    ("The subject is located to the left", "U"),
    ("High in the frame", "U"),
    ("It made the scene move left", "U"),
    ("Image 2's camera sits above image 1's", "P up"),
]

TABLE = NOUNS + ADVERBS + PASSIVE + OPERATOR + COLLOQUIAL + HEDGES + PLACES + STILL + NEAR_MISSES
TABLE += LABELS_AND_SUBJECTS + KIND_NOUN_MISSES + SETTINGS + EVERYDAY + IDIOMS + ENDINGS + ORIENTATION_NOUNS


def test_the_second_batch_is_large() -> None:
    assert len(TABLE) >= 150


@pytest.mark.parametrize(("wording", "expected"), TABLE)
def test_each_second_batch_wording_reads_as_its_claim(wording: str, expected: str) -> None:
    claim = read_phrase(wording)
    assert short(claim) == expected, (wording, claim)


@pytest.mark.parametrize(("wording", "expected"), NEAR_MISSES + KIND_NOUN_MISSES)
def test_second_batch_near_misses_say_why(wording: str, expected: str) -> None:
    claim = read_phrase(wording)
    assert isinstance(claim, Unread) and claim.why, claim
