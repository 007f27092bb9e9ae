% The NAO assistant of the thesis's use case (7.1.1): T1 the drug reminder, T3 the door bell,
% T4 the trash on the table and T7 help with the red button, with the conflicts of 7.1.3: help
% pre-empts the trash plan (the trash is left on the floor first: the on_preempt wind-down), and
% the bell waits for the trash to be dropped (a lower priority: Waiting-Resource).
% Run: retalisc robapl run nao.apl --events events.jsonl --actions environment.py --plot run.png
% (events_no_answer.jsonl: Mori does not answer the reminder).
agent nao.

beliefs {
  takes(mori, drug_a).
  friend(alice).
  known(Face) :- friend(Face).
  call_ends(P) :- event(heard(P, "OK, I will take A")).
  call_ends(P) :- timeout(10).
}

resources {
  hands: 1.
  legs: 1.
  speaker: 1.
}

rules {
  % T1: at 10 am NAO calls "Take drug A Mori"; the task ends when it hears the answer. A call
  % without an answer ends after 10 s and is made again; after three, NAO calls for emergency
  % assistance (T7's second case): the abstract node is replaced by the plan of the help rule.
  clock(10, 0) <- takes(P, D) | list remind [priority: 5] {
    list ask [repeat: not reminded(P, D), iteration(ask, N), N < 3] {
      external call: say(P, "Take drug A Mori") [resources: <speaker, using, 1>; end: call_ends(P);
                                                 post: event(heard(P, "OK, I will take A"))]
      belief_update noted [start: finished(call); pre: succeeded(call); post: reminded(P, D)]
    }
    abstract emergency: heard(P, "Help!") [start: finished(ask); pre: not reminded(P, D)]
  }

  % T7: on "Help!" NAO walks to the red button and presses it, with its legs and empty hands.
  heard(P, "Help!") <- true | list help [priority: 10; resources: <hands, blocking, 1>, <legs, blocking, 1>] {
    external go: move_to(red_button)
    external press: press(red_button) [start: finished(go)]
    belief_update called [start: finished(press); post: emergency_called(P)]
  }

  % T3: the door bell: go to the door, look at the visitor, open for a known face, else warn.
  bell <- true | list door [priority: 1; resources: <hands, blocking, 1>, <legs, blocking, 1>] {
    external go_door: move_to(door)
    external look: recognise_face(door_camera) [start: finished(go_door); result: Face]
    external open: press(open_door_button) [start: finished(look); pre: known(Face)]
  }

  % T4: trash on the table: take it to the trash can. Pre-empted, NAO first leaves the trash.
  seen(trash, L) <- not carrying(trash) | list trash [priority: 2] {
    list carry [resources: <hands, blocking, 1>, <legs, blocking, 1>] {
      external walk: move_to(L)
      external pick: pick_up(trash) [start: finished(walk)]
      belief_update holding [start: finished(pick); post: carrying(trash)]
      external to_bin: move_to(trash_can) [start: finished(holding)]
      external drop: put_down(trash, trash_can) [start: finished(to_bin)]
      belief_update empty [start: finished(drop); post: not carrying(trash)]
    }
    on_preempt wind {
      external leave: put_down(trash, floor) [pre: carrying(trash); resources: <hands, blocking, 1>]
      belief_update left [start: finished(leave); pre: carrying(trash); post: not carrying(trash), trash_on(floor)]
    }
  }
}
