% The NAO assistant of the thesis's use case (7.1.1): T1 the drug reminder, T2 the drug box
% check, T3 the door bell, T4 the trash on the table, T5 where-is-my-key, T6 drinks and T7 help
% with the red button, with the conflicts of 7.1.3: help pre-empts the trash plan (the trash is
% left on the floor first: the on_preempt wind-down), the bell waits for the trash to be dropped
% (a lower priority: Waiting-Resource), and NAO answers where the key is while it walks to the
% drug box (the two plans share no resource).
% Run: retalisc robapl run nao.apl --events events.jsonl --actions environment.py --plot run.png
% (events_no_answer.jsonl: Mori does not answer the reminder).
agent nao.

beliefs {
  takes(mori, drug_a).
  friend(alice).
  known(Face) :- friend(Face).
  call_ends(P) :- event(heard(P, "OK, I will take A")).
  call_ends(P) :- timeout(10).
  % T2: where the drug box is, how NAO looks at it; Mori's answer to "have you ordered?"
  drug_box(drug_a, drug_shelf, down_left).
  order_answer(A) :- event(heard(mori, A)).
  order_answer(none) :- timeout(20).
  % T6: the drinks on the kitchen table, where each person sits
  drink(water).
  drink(juice).
  seat(mori, sofa).
  seat(araz, armchair).
}

resources {
  hands: 1.
  legs: 1.
  speaker: 1.
  head: 1.
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

  % T2: every afternoon NAO checks the drug box (7.1.2): it walks to the box and turns its head
  % to it in parallel, lets the camera settle for 2 s once both are done, takes a picture and
  % counts the red pills in the white box. Drug A finished: NAO asks Mori whether he has already
  % ordered more; if he has not (or says nothing for 20 s), NAO orders by e-mail.
  clock(15, 0) <- drug_box(Drug, Place, Gaze) | list drug_box [priority: 3] {
    external walk: move_to(Place) [resources: <legs, blocking, 1>]
    external orient: orient_head(Gaze) [resources: <head, blocking, 1>]
    list settle [start: finished(walk), finished(orient); pre: succeeded(walk), succeeded(orient);
                 end: timeout(2)] {}
    external picture: take_picture(head_camera) [start: finished(settle); pre: succeeded(settle);
                                                 resources: <head, blocking, 1>; result: Image]
    external count: count_pills(Image, red, white_box) [start: finished(picture); pre: succeeded(picture);
                                                        result: N]
    external ask: say(mori, "Have you already ordered drug A?") [start: finished(count); pre: succeeded(count), N = 0;
                                                                 resources: <speaker, using, 1>; end: order_answer(Answer)]
    external order: send_email(drugstore, "Please deliver drug A for Mori") [start: finished(ask);
                                                                              pre: succeeded(ask), Answer \= "Yes"]
    belief_update ordered [start: finished(order); pre: succeeded(order); post: ordered(Drug)]
  }

  % T5: NAO keeps where each person's things are. The person speaking is the one NAO last saw in
  % front of its camera, or who introduced themself ("It's Mori": the same plan, through an
  % abstract node); the speech understanding gives told(remember(Object, Place)) and
  % asked(where_is(Object)).
  face(P) <- true | list attend {
    belief_update forget [post: not speaker(Other)]
    belief_update attend [start: finished(forget); post: speaker(P)]
  }
  introduced(P) <- true | list introduce {
    abstract who: face(P)
  }
  told(remember(Object, Place)) <- speaker(P) | list remember [priority: 4] {
    belief_update forget [post: not place(P, Object, Old)]
    belief_update store [start: finished(forget); post: place(P, Object, Place)]
    external ack: say(P, "OK, I will remember") [start: finished(store); resources: <speaker, using, 1>]
  }
  asked(where_is(Object)) <- speaker(P), place(P, Object, Place) | list answer [priority: 4] {
    external tell: say(P, on(Place)) [resources: <speaker, using, 1>]
  }
  asked(where_is(Object)) <- speaker(P), not place(P, Object, Place) | list dont_know [priority: 4] {
    external tell: say(P, "I do not know") [resources: <speaker, using, 1>]
  }

  % T6: bring a drink from the kitchen table to the person who asked, at their seat.
  asked(bring(Drink)) <- speaker(P), drink(Drink), seat(P, Seat) | list drinks [priority: 3] {
    list fetch [resources: <hands, blocking, 1>, <legs, blocking, 1>] {
      external to_kitchen: move_to(kitchen_table)
      external pick: pick_up(Drink) [start: finished(to_kitchen); pre: succeeded(to_kitchen)]
      external back: move_to(Seat) [start: finished(pick); pre: succeeded(pick)]
      external give: hand_over(Drink, P) [start: finished(back); pre: succeeded(back)]
    }
    belief_update served [start: finished(fetch); pre: succeeded(give); post: served(P, Drink)]
  }
}
