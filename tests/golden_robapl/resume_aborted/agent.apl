% A node whose ancestor fails while it is Resuming goes Failing: its on_resume list is aborted
% (it is not the wind-down of a failure), and its on_abort list runs before it finishes.
rules {
  go <- true | list plan [invariant: not event(crash)] {
    list sleepy [pause: event(nap); resume: event(wake)] {
      external z: long(z, 100)
      on_resume r { external slow_wake: long(s, 100) }
      on_abort a { external tidy: act(t) }
    }
  }
}
