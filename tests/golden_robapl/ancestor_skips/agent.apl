% One event ends a child and breaks its parent's invariant in the same micro step: the child,
% Iteration-Ended, is finished by the failing parent; a child waiting for a resource (held by a
% plan of a higher priority, so it does not pre-empt it) is skipped.
resources { arm: 1. }
rules {
  hog <- true | list hog [priority: 5; resources: <arm, using, 1>] { external h: long(h, 100) }
  go <- true | list plan [invariant: not event(crash)] {
    external a: long(a, 10) [end: event(crash)]
    external needs: act(n) [resources: <arm, using, 1>]
  }
}
