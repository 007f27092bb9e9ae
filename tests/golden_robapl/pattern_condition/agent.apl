% The iec_condition case with its start condition written as an event pattern: compiled to the
% ELE rule visitor(P) <- (at_door(P) seq bell).10. of the agent's IEC (retalisc/robapl/patterns.py).
rules {
  bell <- true | list greet {
    external hello: act(P) [start: visitor(P) <- {(at_door(P) seq bell).10}]
  }
}
