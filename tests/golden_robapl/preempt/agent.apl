% A higher-priority plan needs the resource a lower-priority plan holds: the lower plan is
% pre-empted; its wind-down (on_preempt) runs bottom-up, the inner one first, before the root ends.
resources { hands: 1. }
rules {
  chore <- true | list low [priority: 1] {
    list inner [resources: <hands, blocking, 1>] {
      external carry: long(box, 10)
      on_preempt inner_down { external put: act(box) }
    }
    on_preempt outer_down { external note: act(log) }
  }
  urgent <- true | list high [priority: 9; resources: <hands, blocking, 1>] { external help: act(h) }
}
