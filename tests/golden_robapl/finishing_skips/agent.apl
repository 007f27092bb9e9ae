% A list whose end condition holds goes Finishing: a child still waiting to start is skipped
% (PLEXIL: the parent's end); then a pre-empt condition fails the Finishing root, and the
% Finishing inner list fails with it (parent_preempted).
rules {
  go <- true | list plan [end: event(wrap); preempt: event(kick)] {
    list inner [end: event(wrap)] {
      external w: long(w, 50)
      external later: act(l) [start: event(never)]
    }
  }
}
