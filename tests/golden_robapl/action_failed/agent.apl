% An action that fails at once: Executing -> Iteration-Ended with failure; the post condition
% of a list that does not hold gives the list the outcome failure.
rules {
  go <- true | list plan [post: succeeded(bad)] {
    external bad: broken(x)
  }
}
