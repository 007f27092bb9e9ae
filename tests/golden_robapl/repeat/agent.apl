% Repeat: Iteration-Ended -> Waiting while the repeat condition holds (checked once, at the end of
% each iteration). Both children start in the same micro step and see the same snapshot: in the
% first iteration only r2's pre condition holds, in the second only r3's.
beliefs { round(1). }
rules {
  go <- true | list plan {
    list loop [repeat: not round(3)] {
      belief_update r2 [pre: round(1); post: not round(1), round(2)]
      belief_update r3 [pre: round(2); post: not round(2), round(3)]
    }
  }
}
