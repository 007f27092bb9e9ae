% An invariant that stops holding: the list fails, its executing child fails with
% parent_failure, its waiting child is skipped, and the on_abort wind-down runs first.
beliefs { safe. }
rules {
  go <- true | list plan [invariant: safe] {
    external work: long(w, 5)
    external later: act(l) [start: finished(work)]
    on_abort cleanup { external tidy: act(t) }
  }
  danger <- true | list alarm { belief_update unsafe [post: not safe] }
}
