% A list whose end condition holds while a child still runs goes Finishing; an invariant that
% stops holding there fails it (PLEXIL: Finishing -> Failing); a paused node whose parent fails
% is finished with the parent's outcome.
beliefs { ok. }
rules {
  go <- true | list plan [end: event(enough); invariant: ok] {
    external slow: long(s, 10)
    list waiter [pause: event(enough); resume: event(never)] { external idle: long(i, 20) }
  }
  stop <- true | list breaker { belief_update broke [post: not ok] }
}
