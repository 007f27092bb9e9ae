% A list of two actions in sequence: the nominal path of every node (thesis 7.2.3).
rules {
  go <- true | list plan {
    external first: act(one)
    external second: long(two, 2) [start: finished(first)]
  }
}
