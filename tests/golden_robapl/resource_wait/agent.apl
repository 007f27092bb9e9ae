% Two plans of the same priority want the one arm: the second waits (Waiting-Resource) until
% the first releases it, then goes Waiting again and starts.
resources { arm: 1. }
rules {
  first <- true | list a [resources: <arm, using, 1>] { external hold: long(a, 3) }
  second <- true | list b [resources: <arm, using, 1>] { external hold: long(b, 1) }
}
