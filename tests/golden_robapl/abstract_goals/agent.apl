% An abstract node replaced by the plan of a rule; a goal adopted by a goal_update is an event
% of the event base that plans for it; a test node binds a variable for the nodes after it.
beliefs { place(cup, kitchen). }
rules {
  go <- true | list plan {
    test where: place(cup, Where)
    abstract fetch: fetch(cup, Where) [start: finished(where)]
    goal_update want: adopt(clean(Where)) [start: finished(fetch)]
  }
  fetch(Thing, Place) <- true | list fetching { external grab: act(Thing, Place) }
  clean(Place) <- true | list cleaning { external wipe: act(Place) }
}
