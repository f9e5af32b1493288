"""The stages of one solve, in order (the paper's Figure 2), each filling its step record:

- `scene`: upload the photos or look up the scene (SceneStep), reconstruct it (ReconstructionStep);
- `program`: a program from the code model (repaired when it fails) or the offline planner
  (ProgramStep), each run in the sandbox (`execution`: ExecutionStep);
- `clue`: what the program that ran produced, as the answerer and the response see it;
- `answer`: the answer from the clue, or from the photos alone when no program ran (AnswerStep).

services/agent/pipeline.py runs them; services/agent/response.py makes the response of the records.
"""
