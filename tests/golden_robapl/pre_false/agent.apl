% A pre condition that does not hold: Waiting -> Iteration-Ended (failure); a list whose pre
% fails leaves its children Inactive, and they are skipped when it finishes (PLEXIL).
beliefs { ready(no). }
rules {
  go <- true | list plan {
    external gated: act(x) [pre: ready(yes)]
    list inner [pre: ready(yes)] { external never: act(y) }
  }
}
