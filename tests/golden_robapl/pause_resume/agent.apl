% Pause and resume (thesis 7.2.3): the list pauses on `halt`, fails its running child, runs
% on_pause, waits Paused; on `go_on` it runs on_resume and goes Waiting; the finished child
% stays finished and the interrupted one runs again.
rules {
  go <- true | list plan [pause: event(halt); resume: event(go_on)] {
    external one: act(one)
    external two: long(two, 5) [start: finished(one)]
    on_pause stop { external brake: act(brake) }
    on_resume restart { external warm: act(warm) }
  }
}
